#!/usr/bin/python3
"""bake --env with OpenEXR maps as HDRI tools write them (docs/envmap.md): a half-float RGBA
scanline ZIP map bakes end to end, exactly as the float RGB map of the same values; a map with
a NaN texel is refused with exit 2, one stderr line and no output. The maps are written by
tests/exrfile.py, independent of the OpenEXR library the tool reads them with."""
import math
import os
import shutil
import struct
import subprocess
import tempfile
import unittest

import pyopenvdb as vdb

from exrfile import write_exr

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]

def sky(width, height):
    """A bright upper half with a warm spot, values exact in half precision."""
    planes = {c: [[0.0] * width for _ in range(height)] for c in "RGB"}
    for y in range(height):
        for x in range(width):
            for k, c in enumerate("RGB"):
                v = (2.0 if y < height // 2 else 0.25) * (1.0 + 0.5 * math.sin(0.4 * x + k))
                if abs(x - width // 3) <= 1 and abs(y - height // 4) <= 1:
                    v = 40.0 - 8.0 * k
                planes[c][y][x] = struct.unpack("<e", struct.pack("<e", v))[0]
    return planes


def flat(planes):
    """{name: rows} as the writer's {name: flat list}."""
    return {n: [v for row in rows for v in row] for n, rows in planes.items()}


def run(*args):
    return subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)


class HalfExrMaps(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def bake(self, env, out):
        return run("bake", os.path.join(SAMPLES, "cloud.vdb"), "-o", self.path(out), "--env", env,
                   "--density-scale", "20", "--quality", "low", "-q")

    def test_half_rgba_bakes_as_float_rgb(self):
        w, h = 32, 16
        planes = sky(w, h)
        rgba = dict(planes, A=[[1.0] * w for _ in range(h)])
        write_exr(self.path("half_rgba.exr"), w, h, flat(rgba), half=True, compression="zip")
        write_exr(self.path("float_rgb.exr"), w, h, flat(planes))
        p = self.bake(self.path("half_rgba.exr"), "half.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        p = self.bake(self.path("float_rgb.exr"), "float.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        a = {tuple(i.min): i.value for i in vdb.read(self.path("half.vdb"), "radiance").citerOnValues()}
        b = {tuple(i.min): i.value for i in vdb.read(self.path("float.vdb"), "radiance").citerOnValues()}
        self.assertEqual(a.keys(), b.keys())
        self.assertGreater(max(max(v) for v in a.values()), 0.0)
        for key, v in a.items():
            self.assertEqual(v, b[key])

    def test_nan_texel_refused(self):
        w, h = 32, 16
        planes = sky(w, h)
        planes["G"][5][7] = float("nan")
        rgba = dict(planes, A=[[1.0] * w for _ in range(h)])
        write_exr(self.path("nan.exr"), w, h, flat(rgba), half=True, compression="zip")
        p = self.bake(self.path("nan.exr"), "out.vdb")
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn("not finite", lines[0])
        self.assertIn("nan.exr", lines[0])
        self.assertEqual(os.listdir(self.dir), ["nan.exr"])


if __name__ == "__main__":
    unittest.main()
