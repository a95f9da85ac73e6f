#!/usr/bin/python3
"""`bake --method auto --tolerance E`: the plan is the cheapest candidate predicted within E
(checked by brute force over the candidates the dry run lists), tighter tolerances never
buy a cheaper plan, an unreachable tolerance is refused naming the best, weak lights are
left out, the plan reaches the report and the lit VDB, and on the bundled cloud the bake
meets its tolerance against a Monte-Carlo reference whose noise is below E/4 (error at
most E + 2 standard errors, fixed seeds)."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
CLOUD = os.path.join(SAMPLES, "cloud.json")
SMOKE = os.path.join(SAMPLES, "smoke.json")


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


class Plan(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.tmp, name)

    def dry(self, scene, tolerance, *extra):
        p = run("bake", "--scene", scene, "-o", self.path("dry.vdb"), "--method", "auto",
                "--tolerance", tolerance, "--dry-run", "--json", *extra, check=0)
        self.assertFalse(os.path.exists(self.path("dry.vdb")), "a dry run wrote a file")
        return json.loads(p.stdout)["plan"]

    def test_cheapest_within_tolerance(self):
        for scene in (CLOUD, SMOKE):
            last = 0.0
            for e in (0.5, 0.3, 0.15, 0.08, 0.04, 0.02):
                plan = self.dry(scene, e)
                cands = plan["candidates"]
                self.assertGreater(len(cands), 0, plan)
                ok = [c for c in cands if c["predicted_error"] <= e]
                if ok:
                    best = min(ok, key=lambda c: c["predicted_seconds"])
                    self.assertTrue(plan["reachable"])
                    self.assertLessEqual(plan["predicted_error"], e)
                    self.assertAlmostEqual(plan["predicted_seconds"], best["predicted_seconds"])
                    self.assertGreaterEqual(plan["predicted_seconds"], last - 1e-12, (scene, e))
                    last = plan["predicted_seconds"]
                else:
                    self.assertFalse(plan["reachable"])
                    self.assertAlmostEqual(plan["predicted_error"],
                                           min(c["predicted_error"] for c in cands))

    def test_unreachable_is_refused(self):
        out = self.path("lit.vdb")
        p = run("bake", "--scene", CLOUD, "-o", out, "--method", "auto", "--tolerance", "0.0001")
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn("out of reach", lines[0])
        self.assertIn("--method", lines[0])
        self.assertFalse(os.path.exists(out))

    def test_flag_errors(self):
        out = self.path("lit.vdb")
        for args, needle in ((["--tolerance", "0.1"], "--method auto"),
                             (["--dry-run"], "--method auto"),
                             (["--method", "auto", "--tolerance", "0"], "--tolerance"),
                             (["--method", "auto", "--tolerance", "1.5"], "--tolerance"),
                             (["--method", "auto", "--tolerance", "x"], "--tolerance"),
                             (["--method", "auto", "--keep-state"], "--keep-state")):
            p = run("bake", "--scene", CLOUD, "-o", out, *args)
            self.assertEqual(p.returncode, 2, (args, p.stderr))
            self.assertIn(needle, p.stderr, args)
            self.assertFalse(os.path.exists(out))

    def test_weak_light_left_out(self):
        """A point light of a millionth of the sun's power is below E/8 of it: left out,
        and the bake's scene has the sun alone."""
        plan = self.dry(CLOUD, 0.2, "--sun", "0.3,-1,0.2:3,3,3", "--point", "2,0,0:1e-6,1e-6,1e-6")
        self.assertEqual(plan["skipped_lights"], [1], plan)
        shares = plan["features"]["light_share"]
        self.assertLess(shares[1], 1e-5)
        self.assertAlmostEqual(sum(shares), 1.0, places=9)
        rep = json.loads(run("bake", "--scene", CLOUD, "-o", self.path("weak.vdb"), "--method",
                             "auto", "--tolerance", "0.2", "--sun", "0.3,-1,0.2:3,3,3",
                             "--point", "2,0,0:1e-6,1e-6,1e-6", "--json", "-q",
                             check=0).stdout)
        self.assertEqual(len(rep["scene"]["lights"]), 1, rep["scene"])
        self.assertEqual(rep["scene"]["lights"][0]["type"], "sun")

    def test_meets_tolerance_on_the_cloud(self):
        e = 0.15
        lit = self.path("auto.vdb")
        rep = json.loads(run("bake", "--scene", CLOUD, "-o", lit, "--method", "auto",
                             "--tolerance", e, "--json", "-q", check=0).stdout)
        plan = rep["plan"]
        self.assertTrue(plan["reachable"])
        self.assertEqual(rep["method"], plan["method"])
        self.assertEqual(rep["quality"], plan["quality"])
        with open(lit, "rb") as f:
            self.assertIn(b"vdbscatter_plan", f.read(), "the plan is not in the lit VDB")
        img, ref = self.path("auto.exr"), self.path("ref.exr")
        run("render", lit, "-o", img, "--size", "64x48", "-q", check=0)
        run("render", "--scene", CLOUD, "--mode", "reference", "--size", "64x48", "--spp",
            "1024", "--seed", "3", "-o", ref, "-q", check=0)
        c = json.loads(run("compare", img, ref, "--json", check=0).stdout)
        self.assertLess(c["se_b"], e / 4, c)
        err = c["relrmse"] * max(0.0, 1.0 - c["noise_share"]) ** 0.5
        # the estimate's spread is below the reference's noise: 2 se_b bounds 2 standard errors
        self.assertLessEqual(err, e + 2 * c["se_b"], (plan, c))


if __name__ == "__main__":
    unittest.main()
