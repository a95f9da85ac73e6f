#!/usr/bin/python3
"""`vdbscatter compare` as a pipeline meets it: key=value and JSON output on images with
known answers, se statistics, masking, and bad input (exit 2, one line). The images are
written by tiny pure-Python writers (PNG here, OpenEXR in tests/exrfile.py: scanline,
uncompressed or ZIP, half or float), so the reader is also checked against files it did not
write itself."""
import json
import math
import os
import random
import shutil
import struct
import subprocess
import tempfile
import unittest
import zlib

from exrfile import write_exr

EXE = os.environ["VDBSCATTER"]


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def parse(stdout):
    """key=value lines as an ordered list of (key, value) pairs."""
    return [tuple(line.split("=", 1)) for line in stdout.splitlines() if line]


def write_png(path, width, height, rgb, depth=8):
    """rgb: flat list of integer code values, row 0 on top."""
    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    fmt = ">%dH" % (3 * width) if depth == 16 else "%dB" % (3 * width)
    rows = b"".join(b"\0" + struct.pack(fmt, *rgb[3 * width * y: 3 * width * (y + 1)]) for y in range(height))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(rows)))
        f.write(chunk(b"IEND", b""))


def rgb_channels(values, se=None):
    """Flat interleaved RGB (and se) lists as EXR channel planes."""
    ch = {"R": values[0::3], "G": values[1::3], "B": values[2::3]}
    if se is not None:
        ch.update({"se.R": se[0::3], "se.G": se[1::3], "se.B": se[2::3]})
    return ch


class Base(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))
        self.rng = random.Random(7)

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_bad_input(self, args, needle):
        """Exit 2, nothing on stdout, one line on stderr containing needle."""
        p = run(*args)
        self.assertEqual(p.returncode, 2, f"{args}: {p.stderr}")
        self.assertEqual(p.stdout, "", f"{args}")
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, f"{args}: expected one error line, got {p.stderr!r}")
        self.assertIn(needle.lower(), lines[0].lower(), f"{args}")
        return lines[0]

    def random_exr(self, name, width=24, height=16, se=False, scale=1.0, half=False):
        """Values are multiples of 1/64 in [1/64, 2], exact in half and after scaling by 1.25."""
        rng = random.Random(11)
        n = 3 * width * height
        values = [scale * rng.randint(1, 128) / 64.0 for _ in range(n)]
        errors = [rng.randint(1, 8) / 256.0 for _ in range(n)] if se else None
        path = self.path(name)
        write_exr(path, width, height, rgb_channels(values, errors), half=half)
        return path


class Compare(Base):
    def test_help(self):
        p = run("compare", "--help", check=0)
        self.assertIn("usage: vdbscatter compare", p.stdout)
        self.assertIn("--mask-below", p.stdout)
        self.assertIn("compare A B", run("--help", check=0).stdout)

    def test_self_png(self):
        w, h = 17, 9
        codes = [self.rng.randrange(256) for _ in range(3 * w * h)]
        a = self.path("a.png")
        write_png(a, w, h, codes)
        p = run("compare", a, a, check=0)
        self.assertEqual(p.stdout.splitlines()[0], "relrmse=0")
        self.assertEqual(parse(p.stdout), [("relrmse", "0"), ("mean_rel", "0"), ("p99_rel", "0"),
                                           ("mean_ratio", "1"), ("samples", str(3 * w * h))])
        self.assertEqual(p.stderr, "")

    def test_png_16_bit_and_misnamed(self):
        """A 16-bit PNG of the same code values (v * 257) decodes to the same linear image;
        the format comes from the content, not the name."""
        w, h = 8, 4
        codes = [self.rng.randrange(256) for _ in range(3 * w * h)]
        a, b = self.path("a8.png"), self.path("b16.dat")
        write_png(a, w, h, codes)
        write_png(b, w, h, [257 * c for c in codes], depth=16)
        p = run("compare", a, b, check=0)
        self.assertLess(float(dict(parse(p.stdout))["relrmse"]), 1e-6)

    def test_scaled_copy(self):
        b = self.random_exr("b.exr")
        a = self.random_exr("a.exr", scale=1.25)
        m = dict(parse(run("compare", a, b, check=0).stdout))
        self.assertAlmostEqual(float(m["relrmse"]), 0.25, delta=1e-6)
        self.assertAlmostEqual(float(m["mean_rel"]), 0.25, delta=0.25 * 0.01)
        self.assertLessEqual(float(m["p99_rel"]), 0.25 + 1e-6)
        self.assertNotIn("noise_share", m)
        # PNG: the same within 8-bit quantisation.
        w, h = 16, 16
        lin = [self.rng.uniform(0.2, 0.6) for _ in range(3 * w * h)]
        enc = lambda v: round(255 * (1.055 * v ** (1 / 2.4) - 0.055))
        write_png(self.path("b.png"), w, h, [enc(v) for v in lin])
        write_png(self.path("a.png"), w, h, [enc(1.5 * v) for v in lin])
        m = dict(parse(run("compare", self.path("a.png"), self.path("b.png"), check=0).stdout))
        self.assertAlmostEqual(float(m["relrmse"]), 0.5, delta=0.02)

    def test_json(self):
        b = self.random_exr("b.exr", se=True)
        a = self.random_exr("a.exr", se=True, scale=1.25)
        p = run("compare", a, b, "--json", check=0)
        j = json.loads(p.stdout)
        keys = ["relrmse", "mean_rel", "p99_rel", "mean_ratio", "samples", "noise_share",
                "z_mean", "z_rms", "z_samples", "se_a", "se_b"]
        self.assertEqual(list(j), keys)
        for k in keys:
            self.assertIsInstance(j[k], (int, float), k)
        self.assertEqual(j["samples"], 3 * 24 * 16)
        self.assertAlmostEqual(j["relrmse"], 0.25, delta=1e-6)
        self.assertAlmostEqual(j["mean_ratio"], 1.25, delta=1e-6)
        text = parse(run("compare", a, b, check=0).stdout)
        self.assertEqual([k for k, _ in text], keys)
        for k, v in text:
            self.assertAlmostEqual(float(v), j[k], delta=1e-8 * max(1.0, abs(j[k])), msg=k)
        # A reference without se counts as exact: z statistics use A's noise alone.
        plain = self.random_exr("plain.exr")
        j = json.loads(run("compare", a, plain, "--json", check=0).stdout)
        self.assertEqual(list(j), ["relrmse", "mean_rel", "p99_rel", "mean_ratio", "samples",
                                   "noise_share", "z_mean", "z_rms", "z_samples", "se_a"])

    def test_noise_statistics(self):
        """A = B + sqrt(se_A^2 + se_B^2) N(0,1): z ~ N(0,1) and the noise explains the
        whole difference."""
        w, h = 64, 64
        n = 3 * w * h
        b = [self.rng.uniform(0.5, 1.5) for _ in range(n)]
        sb = [self.rng.uniform(0.01, 0.05) for _ in range(n)]
        sa = [self.rng.uniform(0.01, 0.05) for _ in range(n)]
        a = [b[i] + math.hypot(sa[i], sb[i]) * self.rng.gauss(0, 1) for i in range(n)]
        write_exr(self.path("a.exr"), w, h, rgb_channels(a, sa))
        write_exr(self.path("b.exr"), w, h, rgb_channels(b, sb))
        m = dict(parse(run("compare", self.path("a.exr"), self.path("b.exr"), check=0).stdout))
        self.assertAlmostEqual(float(m["z_rms"]), 1.0, delta=0.05)
        self.assertLess(abs(float(m["z_mean"])), 4 / math.sqrt(n))
        self.assertAlmostEqual(float(m["noise_share"]), 1.0, delta=0.05)

    def test_half_and_tiled_files(self):
        """Half channels with a data window off the origin, and (when OpenEXR's tools are
        installed) a tiled multi-resolution copy, read like the plain float file."""
        b = self.random_exr("b.exr", se=True)
        rng = random.Random(11)
        n = 3 * 24 * 16
        values = [rng.randint(1, 128) / 64.0 for _ in range(n)]
        errors = [rng.randint(1, 8) / 256.0 for _ in range(n)]
        write_exr(self.path("h.exr"), 24, 16, rgb_channels(values, errors), half=True, origin=(-5, 3))
        m = dict(parse(run("compare", self.path("h.exr"), b, check=0).stdout))
        self.assertEqual(m["relrmse"], "0")
        self.assertEqual(m["z_rms"], "0")
        tool = shutil.which("exrmaketiled")
        if tool is None:
            self.skipTest("exrmaketiled not installed")
        tiled = self.path("tiled.exr")
        subprocess.run([tool, "-m", "-t", "8", "5", b, tiled], check=True, capture_output=True)
        m = dict(parse(run("compare", tiled, b, check=0).stdout))
        self.assertEqual(m["relrmse"], "0")
        self.assertEqual(m["se_a"], m["se_b"])

    def test_half_rgba_zip_against_float(self):
        """Half RGBA ZIP, the layout most tools write (OpenEXRCore 3.1.5's decoder crashed on
        it, exit 139), against a float copy of the same values: they differ by half rounding
        alone, and not at all against a float copy of the rounded values."""
        w, h = 40, 37  # three ZIP blocks, the last one of 5 lines
        n = w * h
        values = [self.rng.uniform(0.01, 4.0) for _ in range(3 * n)]
        rgba = rgb_channels(values)
        rgba["A"] = [1.0] * n
        half, full = self.path("half.exr"), self.path("float.exr")
        write_exr(half, w, h, rgba, half=True, compression="zip")
        write_exr(full, w, h, rgb_channels(values), compression="zip")
        p = run("compare", half, full, check=0)
        m = dict(parse(p.stdout))
        self.assertEqual(m["samples"], str(3 * n))
        self.assertGreater(float(m["relrmse"]), 0.0)
        self.assertLess(float(m["relrmse"]), 1e-3)
        rounded = [struct.unpack("<e", struct.pack("<e", v))[0] for v in values]
        write_exr(full, w, h, rgb_channels(rounded))
        self.assertEqual(dict(parse(run("compare", half, full, check=0).stdout))["relrmse"], "0")

    def test_grey_and_render_output(self):
        """Y alone reads as grey (R = G = B = Y), as for environment maps; an image rendered
        with --mode reference reads back with its se channels."""
        write_exr(self.path("grey.exr"), 24, 16, {"Y": [0.5] * (24 * 16)}, half=True, compression="zip")
        write_exr(self.path("rgb.exr"), 24, 16, rgb_channels([0.5] * (3 * 24 * 16)))
        m = dict(parse(run("compare", self.path("grey.exr"), self.path("rgb.exr"), check=0).stdout))
        self.assertEqual(m["relrmse"], "0")
        samples = os.environ.get("VDBSCATTER_SAMPLES_DIR")
        if not samples:
            self.skipTest("VDBSCATTER_SAMPLES_DIR not set")
        ref = self.path("ref.exr")
        run("render", os.path.join(samples, "cube.vdb"), "--scene", os.path.join(samples, "cube.json"),
            "-o", ref, "-q", "--size", "12x10", "--mode", "reference", "--spp", "2", "--max-bounces", "3",
            "--seed", "7", check=0)
        j = json.loads(run("compare", ref, ref, "--json", check=0).stdout)
        self.assertEqual(j["relrmse"], 0)
        self.assertGreater(j["se_a"], 0)
        self.assertEqual(j["se_a"], j["se_b"])
        self.assertGreater(j["z_samples"], 0)

    def test_mask_below(self):
        w, h = 10, 6
        ref, test = [], []
        for y in range(h):
            for x in range(w):
                dark = x < 4
                ref += [0.01 if dark else 1.0] * 3
                test += [3.0 if dark else 1.0] * 3
        write_exr(self.path("a.exr"), w, h, rgb_channels(test))
        write_exr(self.path("b.exr"), w, h, rgb_channels(ref))
        args = ["compare", self.path("a.exr"), self.path("b.exr")]
        self.assertEqual(dict(parse(run(*args, check=0).stdout))["samples"], str(3 * w * h))
        m = dict(parse(run(*args, "--mask-below", "0.5", check=0).stdout))
        self.assertEqual(m["samples"], str(3 * 6 * h))
        self.assertEqual(m["relrmse"], "0")
        m = dict(parse(run(*args, "--mask-below=0.5", check=0).stdout))
        self.assertEqual(m["samples"], str(3 * 6 * h))
        self.assert_bad_input(args + ["--mask-below", "5"], "luminance")
        self.assert_bad_input(args + ["--mask-below", "-1"], "--mask-below")
        self.assert_bad_input(args + ["--mask-below", "dark"], "--mask-below")

    def test_black_reference(self):
        write_exr(self.path("zero.exr"), 4, 4, rgb_channels([0.0] * 48))
        write_exr(self.path("one.exr"), 4, 4, rgb_channels([1.0] * 48))
        p = run("compare", self.path("zero.exr"), self.path("zero.exr"), check=0)
        self.assertEqual(p.stdout.splitlines()[0], "relrmse=0")
        p = run("compare", self.path("one.exr"), self.path("zero.exr"), check=0)
        self.assertEqual(p.stdout.splitlines()[0], "relrmse=inf")
        j = json.loads(run("compare", self.path("one.exr"), self.path("zero.exr"), "--json", check=0).stdout)
        self.assertIsNone(j["relrmse"])
        self.assertIsNone(j["mean_rel"])

    def test_bad_input(self):
        a = self.random_exr("a.exr")
        small = self.random_exr("small.exr", width=12)
        line = self.assert_bad_input(["compare", a, small], "size")
        self.assertIn("24x16", line)
        self.assertIn("12x16", line)
        missing = self.path("missing.exr")
        self.assertIn(missing, self.assert_bad_input(["compare", a, missing], "missing.exr"))
        self.assert_bad_input(["compare", missing, a], "missing.exr")
        with open(self.path("notes.exr"), "w") as f:
            f.write("not an image\n")
        self.assert_bad_input(["compare", self.path("notes.exr"), a], "notes.exr")
        # Y alone reads as grey (test_grey_and_render_output); no R, G, B or Y is refused.
        write_exr(self.path("depth.exr"), 24, 16, {"Z": [0.5] * (24 * 16)})
        self.assertIn("R, G", self.assert_bad_input(["compare", self.path("depth.exr"), a], "depth.exr"))
        with open(a, "rb") as f:
            data = f.read()
        with open(self.path("cut.exr"), "wb") as f:
            f.write(data[: len(data) // 2])
        self.assert_bad_input(["compare", self.path("cut.exr"), a], "cut.exr")
        with open(self.path("cut.png"), "wb") as f:
            write_png(self.path("full.png"), 8, 8, [100] * 192)
            with open(self.path("full.png"), "rb") as g:
                f.write(g.read()[:40])
        self.assert_bad_input(["compare", self.path("cut.png"), self.path("full.png")], "cut.png")
        self.assert_bad_input(["compare", a], "two images")
        self.assert_bad_input(["compare", a, a, a], "two images")
        self.assert_bad_input(["compare", a, a, "--frobnicate"], "--frobnicate")


if __name__ == "__main__":
    unittest.main()
