#!/usr/bin/python3
"""`bake -o OUT.nvdb` (docs/lit-vdb.md#nanovdb): a NanoVDB file with the grids of the same bake
to .vdb and an OUT.nvdb.json sidecar whose keys are the .vdb's file metadata; another
extension is refused (exit 2, one line, no file); render refuses a .nvdb in one line.
Grid-by-grid bit-exactness against OpenVDB is tests/test_nvdb.cpp's."""
import json
import os
import shutil
import struct
import subprocess
import tempfile
import unittest

import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]

NANOVDB_MAGIC = 0x304244566F6E614E  # "NanoVDB0"
# Metadata that differs between two runs of the same bake.
VARYING = {"vdbscatter_solve_seconds"}


def run(*args):
    return subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)


def sample(name):
    return os.path.join(SAMPLES, name)


class NanoVDBOutput(unittest.TestCase):
    def setUp(self):
        root = os.environ.get("VDBSCATTER_TMP")
        if root:
            os.makedirs(root, exist_ok=True)
        self.tmp = tempfile.mkdtemp(prefix="nvdb_", dir=root)

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.tmp, name)

    def bake(self, out):
        p = run("bake", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--method", "single",
                "-o", out, "-q")
        self.assertEqual(p.returncode, 0, p.stderr)
        return p

    def assert_one_line(self, p, needle):
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn(needle, lines[0])

    def test_bake_writes_nvdb_and_sidecar(self):
        lit, nano = self.path("x.vdb"), self.path("x.nvdb")
        self.bake(lit)
        self.bake(nano)
        self.assertEqual(sorted(os.listdir(self.tmp)), ["x.nvdb", "x.nvdb.json", "x.vdb"])
        with open(nano, "rb") as f:
            data = f.read()
        magic, _version, grid_count, codec = struct.unpack_from("<QIHH", data)
        self.assertEqual(magic, NANOVDB_MAGIC)
        self.assertEqual(codec, 0)  # uncompressed
        names = [g["name"] for g in vdb.readAllGridMetadata(lit)]
        self.assertEqual(grid_count, len(names))
        self.assertTrue({"density", "radiance", "ms", "ms_l1x", "ms_l1y", "ms_l1z"} <= set(names))
        self.assertTrue(any(n.startswith("light_depth_") for n in names), names)
        for n in names:
            self.assertIn(n.encode() + b"\0", data, n)
        # The sidecar equals the .vdb's file metadata key for key; values too, but for the
        # solve time, which two runs never share.
        with open(nano + ".json") as f:
            side = json.load(f)
        meta = vdb.readMetadata(lit)
        self.assertEqual(sorted(side), sorted(meta))
        self.assertIn("vdbscatter_scene", side)
        for k, v in meta.items():
            self.assertIsInstance(side[k], str, k)
            if k not in VARYING:
                self.assertEqual(side[k], v, k)
        # JSON values stay JSON text inside strings.
        self.assertEqual(json.loads(side["vdbscatter_scene"]), json.loads(meta["vdbscatter_scene"]))

    def test_bad_suffix_refused(self):
        for name in ["x.txt", "x.nvdb.json", "x"]:
            with self.subTest(name=name):
                p = run("bake", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--method",
                        "single", "-o", self.path(name))
                self.assert_one_line(p, "-o: expected .vdb or .nvdb")
        self.assertEqual(os.listdir(self.tmp), [])

    def test_render_refuses_nvdb(self):
        nano = self.path("x.nvdb")
        self.bake(nano)
        p = run("render", nano, "-o", self.path("x.png"), "--size", "8x6")
        self.assert_one_line(p, "NanoVDB")
        self.assertFalse(os.path.exists(self.path("x.png")))
        p = run("info", nano)
        self.assert_one_line(p, "NanoVDB")


if __name__ == "__main__":
    unittest.main()
