#!/usr/bin/python3
"""`vdbscatter tradeoff` on the bundled cloud at 48x36, two methods at low: the CSV and JSON
agree with each other and with `vdbscatter compare` of the written images (an independent
path through the error metrics), the reference meets its noise target and converges at the
Monte-Carlo rate, single scattering is darker than the reference (it leaves out every
higher order), the second run hits the cache, another medium misses it, the plot is a PNG,
and bad input leaves no folder behind."""
import csv
import json
import os
import shutil
import struct
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
SCENE = os.path.join(SAMPLES, "cloud.json")
COMMON = ["--scene", SCENE, "--methods", "single,fld", "--qualities", "low", "--size", "48x36",
          "--ref-noise", "0.03", "--json", "-q"]


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n", path
    return struct.unpack(">II", head[16:24])


class Tradeoff(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))
        cls.dir = os.path.join(cls.tmp, "trade")
        # another albedo first, into the same folder: its reference must not serve the next
        cls.other = json.loads(run("tradeoff", "-o", cls.dir, "--scene", SCENE, "--albedo",
                                   "0.7", "--methods", "single", "--qualities", "low", "--size",
                                   "48x36", "--ref-noise", "0.1", "--json", "-q",
                                   check=0).stdout)
        cls.first = json.loads(run("tradeoff", "-o", cls.dir, *COMMON, check=0).stdout)
        cls.second = json.loads(run("tradeoff", "-o", cls.dir, *COMMON, check=0).stdout)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_csv_matches_json(self):
        with open(os.path.join(self.dir, "tradeoff.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual(list(rows[0].keys()),
                         ["method", "quality", "bake_s", "render_s", "total_s", "peak_mib",
                          "relrmse", "relrmse_se", "mean_ratio", "pareto"])
        methods = [r for r in rows if r["method"] != "reference"]
        self.assertEqual([(r["method"], r["quality"]) for r in methods],
                         [("single", "low"), ("fld", "low")])
        for r, j in zip(methods, self.second["rows"]):
            self.assertAlmostEqual(float(r["relrmse"]), j["relrmse"], delta=1e-5 * j["relrmse"])
            self.assertGreater(float(r["bake_s"]), 0.0)
            self.assertGreater(float(r["render_s"]), 0.0)
            self.assertGreater(float(r["peak_mib"]), 1.0)
        curve = [r for r in rows if r["method"] == "reference"]
        self.assertEqual(len(curve), len(self.second["reference"]["curve"]))
        # exactly the rows no other row beats on both time and error are on the front
        for i, a in enumerate(methods):
            beaten = any(float(b["total_s"]) <= float(a["total_s"]) and
                         float(b["relrmse"]) < float(a["relrmse"])
                         for k, b in enumerate(methods) if k != i)
            if beaten:
                self.assertEqual(a["pareto"], "0", a)

    def test_errors_match_compare(self):
        """relrmse with the reference's noise removed: compare's raw relative RMSE times
        sqrt(1 - its noise share), the reference's se being the only noise."""
        ref = os.path.join(self.dir, f"reference-{self.first['reference']['key']}.exr")
        for row in self.first["rows"]:
            img = os.path.join(self.dir, "images", f"{row['method']}-{row['quality']}.exr")
            c = json.loads(run("compare", img, ref, "--json", check=0).stdout)
            expect = c["relrmse"] * max(0.0, 1.0 - c["noise_share"]) ** 0.5
            self.assertAlmostEqual(row["relrmse"], expect, delta=1e-4 * expect + 1e-7, msg=row)
            self.assertAlmostEqual(row["mean_ratio"], c["mean_ratio"], delta=1e-6)
            self.assertGreater(row["relrmse_se"], 0.0)
            self.assertLess(row["relrmse_se"], 0.25 * row["relrmse"], row)

    def test_single_scattering_is_darker(self):
        """At albedo 0.99 most of the cloud's light is scattered more than once: the single
        method misses it, far beyond the reference's noise (0.03 per pixel, less in the sum).
        The observed ratios are 0.88 and 0.997."""
        single = next(r for r in self.first["rows"] if r["method"] == "single")
        fld = next(r for r in self.first["rows"] if r["method"] == "fld")
        # the sky behind the cloud is in both pictures and dilutes the ratio
        self.assertLess(single["mean_ratio"], 0.95, single)
        self.assertGreater(fld["mean_ratio"], 0.95, fld)
        self.assertLess(fld["relrmse"], single["relrmse"])

    def test_reference_noise_and_rate(self):
        ref = self.first["reference"]
        self.assertFalse(ref["cached"])
        self.assertLessEqual(ref["noise"], 1.25 * 0.03, ref)
        curve = ref["curve"]
        self.assertGreaterEqual(len(curve), 3, curve)
        # 4x the samples halve the error: the last two points, whose estimates are steadiest
        a, b = curve[-2], curve[-1]
        self.assertEqual(b["spp"], 4 * a["spp"])
        self.assertGreater(a["relrmse"] / b["relrmse"], 1.5, curve)
        self.assertLess(a["relrmse"] / b["relrmse"], 2.7, curve)

    def test_cache(self):
        a, b = self.first["reference"], self.second["reference"]
        self.assertTrue(b["cached"])
        self.assertEqual(a["key"], b["key"])
        self.assertEqual(a["spp"], b["spp"])
        self.assertAlmostEqual(a["noise"], b["noise"], delta=1e-9)
        self.assertEqual(a["curve"], b["curve"])
        for r1, r2 in zip(self.first["rows"], self.second["rows"]):
            # the bake and render are deterministic on the C path
            self.assertAlmostEqual(r1["relrmse"], r2["relrmse"], delta=1e-6, msg=r1)
        # another albedo is another scene: another key, rendered anew
        self.assertNotEqual(self.other["reference"]["key"], a["key"])
        self.assertFalse(self.other["reference"]["cached"])

    def test_camera_flag(self):
        """--camera frames the reference and the renders (it once failed every run: the
        camera it handed the bakes had no image size); another camera, another reference."""
        cloud = os.path.join(SAMPLES, "cloud.vdb")
        keys = []
        for cam in ["0,0.6,4.5:0,0,0:35", "4.5,0.6,0:0,0,0:35"]:
            out = os.path.join(self.tmp, "camera-" + cam.split(",")[0])
            rep = json.loads(run("tradeoff", cloud, "--sun", "0.3,-1,0.2", "--density-scale",
                                 "20", "--camera", cam, "-o", out, "--methods", "single",
                                 "--qualities", "low", "--size", "24x18", "--ref-noise", "0.3",
                                 "--json", "-q", check=0).stdout)
            self.assertEqual((rep["width"], rep["height"]), (24, 18))
            self.assertEqual([r["method"] for r in rep["rows"]], ["single"])
            keys.append(rep["reference"]["key"])
        self.assertNotEqual(keys[0], keys[1])

    def test_plot_and_summary(self):
        self.assertEqual(png_size(os.path.join(self.dir, "tradeoff.png")), (800, 560))
        md = open(os.path.join(self.dir, "tradeoff.md")).read()
        self.assertIn("Cheapest setting per error level", md)
        self.assertIn("| fld | low |", md)


class BadInput(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def refused(self, args, needle):
        out = os.path.join(self.tmp, "out")
        p = run("tradeoff", *args, "-o", out)
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn(needle, lines[0])
        self.assertFalse(os.path.exists(out), "a refused run made its folder")

    def test_refusals(self):
        self.refused(["--scene", SCENE, "--methods", "fld,nosuch"], "nosuch")
        self.refused(["--scene", SCENE, "--qualities", "best"], "--qualities")
        self.refused(["--scene", SCENE, "--ref-noise", "0"], "--ref-noise")
        self.refused(["--scene", SCENE, "--size", "0x10"], "--size")
        self.refused([os.path.join(self.tmp, "missing.vdb"), "--sun", "0,-1,0"], "missing.vdb")
        self.refused([os.path.join(SAMPLES, "cloud.vdb")], "light")
        p = run("tradeoff", "--scene", SCENE)
        self.assertEqual(p.returncode, 2)
        self.assertIn("-o", p.stderr)

    def test_help(self):
        p = run("tradeoff", "--help", check=0)
        self.assertIn("usage: vdbscatter tradeoff", p.stdout)
        self.assertIn("tradeoff", run("--help", check=0).stdout)


if __name__ == "__main__":
    unittest.main()
