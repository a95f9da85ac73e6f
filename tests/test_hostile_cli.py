#!/usr/bin/python3
"""A VDB file that crashes OpenVDB itself (fuzz/regressions/vdb/openvdb_segfault.vdb, found by
scripts/fuzz.sh: a corrupted blosc block of samples/slab.vdb) is contained
(docs/robustness.md "Hostile input"): info, bake and render each exit 2 with one line naming
the file, and bake and render leave no output file."""
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
        # A segmentation fault in a plain build; under AddressSanitizer the overflow is caught
        # before it and the child ends by abort: either way a crash, contained.
        self.assertRegex(lines[0], r"openvdb_segfault\.vdb: not a valid OpenVDB file \(the "
                         r"OpenVDB reader crashed: (segmentation fault|abort)\)$")
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


if __name__ == "__main__":
    unittest.main()
