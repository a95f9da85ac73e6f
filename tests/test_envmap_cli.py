#!/usr/bin/python3
"""bake --env with OpenEXR maps as HDRI tools write them (docs/envmap.md): a half-float RGBA
scanline ZIP map bakes end to end, exactly as the float RGB map of the same values; a map with
a NaN texel is refused with exit 2, one stderr line and no output. The maps are written here
by a small OpenEXR writer (scanline, half or float, no or ZIP compression), independent of the
OpenEXR library the tool reads them with."""
import math
import os
import shutil
import struct
import subprocess
import tempfile
import unittest
import zlib

import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]

HALF, FLOAT = 1, 2
NO_COMPRESSION, ZIP_COMPRESSION = 0, 3


def zip_block(raw):
    """OpenEXR ZIP: bytes split into even and odd halves, delta-coded, deflated."""
    n = len(raw)
    t = bytearray(raw[0::2] + raw[1::2])
    out = bytearray(t)
    for i in range(1, n):
        out[i] = (t[i] - t[i - 1] + 128 + 256) & 0xFF
    packed = zlib.compress(bytes(out))
    return packed if len(packed) < n else raw


def write_exr(path, width, height, planes, pixel_type, compression):
    """planes: {channel name: rows of floats}; one part, scanlines, data = display window."""
    def attr(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data

    names = sorted(planes)
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", pixel_type, 0, 1, 1)
                      for n in names) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + attr("channels", "chlist", chlist)
              + attr("compression", "compression", bytes([compression]))
              + attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box)
              + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    lines = 16 if compression == ZIP_COMPRESSION else 1
    fmt = "<%d%s" % (width, "e" if pixel_type == HALF else "f")
    chunks = []
    for y0 in range(0, height, lines):
        raw = b"".join(struct.pack(fmt, *planes[n][y])
                       for y in range(y0, min(y0 + lines, height)) for n in names)
        data = zip_block(raw) if compression == ZIP_COMPRESSION else raw
        chunks.append(struct.pack("<ii", y0, len(data)) + data)
    offsets, at = [], len(header) + 8 * len(chunks)
    for c in chunks:
        offsets.append(at)
        at += len(c)
    with open(path, "wb") as f:
        f.write(header + struct.pack("<%dQ" % len(offsets), *offsets) + b"".join(chunks))


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
        write_exr(self.path("half_rgba.exr"), w, h, rgba, HALF, ZIP_COMPRESSION)
        write_exr(self.path("float_rgb.exr"), w, h, planes, FLOAT, NO_COMPRESSION)
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
        write_exr(self.path("nan.exr"), w, h, rgba, HALF, ZIP_COMPRESSION)
        p = self.bake(self.path("nan.exr"), "out.vdb")
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn("not finite", lines[0])
        self.assertIn("nan.exr", lines[0])
        self.assertEqual(os.listdir(self.dir), ["nan.exr"])


if __name__ == "__main__":
    unittest.main()
