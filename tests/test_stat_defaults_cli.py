#!/usr/bin/python3
"""The default bake, as a newcomer runs it (no --method, no --quality: the sample scenes pin
neither), against the Monte-Carlo reference of the same view: image relative RMSE at most
0.15, with the reference's own relative noise (se_b) under 0.03 so that it cannot decide
the outcome. On the cloud sample (samples/cloud.json) and on a real production cloud (the
Disney cloud at 1/16 resolution from the external test data, under cloud.json's sun and sky,
albedo 0.99, g 0.85, --density-scale auto:10). Seeds are fixed, so runs repeat; the
measured values are printed (bench/defaults.md has the same scenes at 160x120)."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
DATA = os.environ.get("VDBSCATTER_DATA_DIR", "")
VIEW = ["--size", "96x72", "--backend", "cpu"]


def run(*args):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900)
    if p.returncode != 0:
        raise AssertionError(f"{args}: exit {p.returncode}: {p.stderr}")
    return p.stdout


class DefaultBake(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="vdbscatter-defaults-",
                                    dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def check(self, scene, spp, name):
        ref = os.path.join(self.dir, "ref.exr")
        run("render", "--scene", scene, "-o", ref, "-q", "--mode", "reference", "--spp", spp,
            "--seed", "5", *VIEW)
        lit = os.path.join(self.dir, "lit.vdb")
        report = json.loads(run("bake", "--scene", scene, "-o", lit, "-q", "--json"))
        self.assertEqual((report["method"], report["quality"]), ("svd", "low"))
        img = os.path.join(self.dir, "baked.exr")
        run("render", lit, "-o", img, "-q", *VIEW)
        c = json.loads(run("compare", img, ref, "--json"))
        print(f"{name}: default bake relrmse {c['relrmse']:.4f}, reference noise se_b "
              f"{c['se_b']:.4f}, bake {report['seconds']['total']:.2f} s, density scale "
              f"{report['density_scale']:.6g}", flush=True)
        self.assertLess(c["se_b"], 0.03)
        self.assertLess(c["relrmse"], 0.15)
        return report

    def test_cloud_sample(self):
        self.check(os.path.join(SAMPLES, "cloud.json"), 1024, "samples/cloud.json")

    def test_disney_cloud_auto_depth(self):
        wdas = os.path.join(DATA, "wdas_cloud_sixteenth.vdb") if DATA else ""
        if not DATA:
            raise unittest.SkipTest("needs the external test data (wdas_cloud_sixteenth.vdb)")
        scene = json.load(open(os.path.join(SAMPLES, "cloud.json")))
        scene["volume"] = {"file": wdas, "density_scale": "auto:10", "albedo": 0.99, "g": 0.85}
        scene.pop("camera")  # the render frames the whole volume
        path = os.path.join(self.dir, "wdas.json")
        with open(path, "w") as fh:
            json.dump(scene, fh)
        report = self.check(path, 2048, "wdas_cloud_sixteenth.vdb")
        # auto:10 resolved against the volume: a mean optical depth of 10 through it.
        self.assertAlmostEqual(report["mean_optical_depth"], 10.0, places=6)


if __name__ == "__main__":
    unittest.main(verbosity=2)
