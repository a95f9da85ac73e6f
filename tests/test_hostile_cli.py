#!/usr/bin/python3
"""A VDB file that crashes OpenVDB itself (fuzz/regressions/vdb/openvdb_segfault.vdb, found by
scripts/fuzz.sh: a corrupted blosc block of samples/slab.vdb) is contained
(docs/robustness.md "Hostile input"): info, bake and render each exit 2 with one line naming
the file, and bake and render leave no output file. What OpenVDB does with it is undefined
(a heap overflow): a segmentation fault where the overflow leaves mapped memory, OpenVDB's own
read error where it does not (it depends on which thread's heap the block lands in), an abort
under AddressSanitizer. So a crash's report is also checked with a reader that crashes for sure
(the test hook VDBSCATTER_FAULT=reader-crash)."""
import os
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
HERE = os.path.dirname(os.path.abspath(__file__))
HOSTILE = os.path.join(HERE, "..", "fuzz", "regressions", "vdb", "openvdb_segfault.vdb")


class HostileVdb(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(dir=os.environ.get("VDBSCATTER_TMP"))

    def check(self, *args, output=None):
        p = subprocess.run([EXE, *args], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = p.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertRegex(lines[0], r"openvdb_segfault\.vdb: (not a valid OpenVDB file \(the "
                         r"OpenVDB reader crashed: (segmentation fault|abort)\)|read error "
                         r"\(corrupt or truncated file\?\))$")
        if output:
            self.assertFalse(os.path.exists(output))

    def test_info(self):
        self.check("info", HOSTILE)

    def test_bake(self):
        out = os.path.join(self.dir, "lit.vdb")
        self.check("bake", HOSTILE, "-o", out, "--sun", "0,-1,0", "--backend", "cpu", "-q",
                   output=out)

    def test_render(self):
        out = os.path.join(self.dir, "r.png")
        self.check("render", HOSTILE, "-o", out, "--sun", "0,-1,0", "--backend", "cpu", "-q",
                   output=out)

    def test_a_crashing_reader_is_reported(self):
        cloud = os.path.join(HERE, "..", "samples", "cloud.vdb")
        out = os.path.join(self.dir, "lit.vdb")
        env = dict(os.environ, VDBSCATTER_FAULT="reader-crash")
        for args in (["info", cloud], ["bake", cloud, "-o", out, "--sun", "0,-1,0", "-q"]):
            p = subprocess.run([EXE, *args], capture_output=True, text=True, timeout=300, env=env)
            self.assertEqual(p.returncode, 2, p.stderr)
            self.assertEqual(p.stderr.strip().splitlines(), [
                f"vdbscatter {args[0]}: {cloud}: not a valid OpenVDB file (the OpenVDB reader "
                "crashed: segmentation fault)"])
            self.assertFalse(os.path.exists(out))


if __name__ == "__main__":
    unittest.main()
