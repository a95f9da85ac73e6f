#!/usr/bin/python3
"""Quality ladders that never get worse, the reduced check: on the bundled cloud and smoke,
every method at low and medium against a Monte-Carlo reference (`vdbscatter tradeoff`, 48x36,
fixed seeds): the error at medium is at most the error at low plus two of the estimates'
standard errors (docs/planner.md has the whole calibration set); and SVD's high step on the
env-map cloud, where 256 sky ordinates measured worse than medium's 64; inet's stop at low."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]


def run(*args):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=1800)
    if p.returncode != 0:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


class Ladder(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def check(self, scene):
        rep = json.loads(run("tradeoff", "--scene", os.path.join(SAMPLES, scene + ".json"), "-o",
                             os.path.join(self.tmp, scene), "--qualities", "low,medium",
                             "--size", "48x36", "--ref-noise", "0.02", "--backend", "cpu",
                             "--json", "-q").stdout)
        rows = {(r["method"], r["quality"]): r for r in rep["rows"]}
        methods = sorted({m for m, _ in rows})
        self.assertGreaterEqual(len(methods), 4, methods)
        worse = []
        for m in methods:
            lo, me = rows[(m, "low")], rows[(m, "medium")]
            bound = lo["relrmse"] + 2.0 * (lo["relrmse_se"] ** 2 + me["relrmse_se"] ** 2) ** 0.5
            print(f"{scene} {m}: low {lo['relrmse']:.4f} +- {lo['relrmse_se']:.4f}, medium "
                  f"{me['relrmse']:.4f} +- {me['relrmse_se']:.4f}")
            if me["relrmse"] > bound:
                worse.append(f"{m} {me['relrmse']:.4f} > {bound:.4f}")
        self.assertEqual(worse, [], f"{scene}: medium is worse than low")

    def test_cloud(self):
        self.check("cloud")

    def test_smoke(self):
        self.check("smoke")

    def test_svd_high_on_the_env_map_cloud(self):
        rep = json.loads(run("tradeoff", "--scene", os.path.join(SAMPLES, "cloud_sky.json"), "-o",
                             os.path.join(self.tmp, "cloud_sky"), "--methods", "svd",
                             "--qualities", "medium,high", "--size", "48x36", "--ref-noise",
                             "0.02", "--backend", "cpu", "--json", "-q").stdout)
        rows = {r["quality"]: r for r in rep["rows"]}
        me, hi = rows["medium"], rows["high"]
        bound = me["relrmse"] + 2.0 * (me["relrmse_se"] ** 2 + hi["relrmse_se"] ** 2) ** 0.5
        print(f"cloud_sky svd: medium {me['relrmse']:.4f} +- {me['relrmse_se']:.4f}, high "
              f"{hi['relrmse']:.4f} +- {hi['relrmse_se']:.4f}")
        self.assertLessEqual(hi["relrmse"], bound)

    def test_inet_bakes_every_quality_as_low(self):
        """inet's ladder stops at low (more particles moved the error both ways): a bake at
        high says so and is low's bake, the same particles, sky, light grids and sweeps."""
        def bake(quality):
            return json.loads(run("bake", "--scene", os.path.join(SAMPLES, "cloud.json"), "-o",
                                  os.path.join(self.tmp, f"inet-{quality}.vdb"), "--method",
                                  "inet", "--quality", quality, "--backend", "cpu", "--json",
                                  "-q").stdout)
        low, high = bake("low"), bake("high")
        self.assertEqual(high["quality"], "high")
        self.assertEqual(high.get("quality_baked"), "low")
        self.assertNotIn("quality_baked", low)
        for key in ("sky_directions", "s1_oversample"):
            self.assertEqual(high[key], low[key], key)
        for key in ("particles", "directions", "iterations", "first_total", "residual"):
            self.assertEqual(high["inet"][key], low["inet"][key], key)


if __name__ == "__main__":
    unittest.main()
