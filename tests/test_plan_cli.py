#!/usr/bin/python3
"""`bake --method auto --tolerance E`: the plan is the cheapest candidate predicted within E
(checked by brute force over the candidates the dry run lists), tighter tolerances never
buy a cheaper plan, an unreachable tolerance bakes the most accurate plan and says so, weak
lights are
left out, the plan reaches the report and the lit VDB, and on the bundled cloud the bake
meets its tolerance against a Monte-Carlo reference whose noise is below E/4 (error at
most E + 2 standard errors, fixed seeds). The error model (a Gaussian process in log error
over the calibration table) against its closed forms: at a calibration scene it predicts
that scene's measured errors, so the plan there is the cheapest method whose measured error
met E; left out of the table, the same scene is predicted with a wider spread; far from
every scene, the spread is the method's spread across the table."""
import json
import math
import os
import shutil
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
CLOUD = os.path.join(SAMPLES, "cloud.json")
TRADEOFF = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench", "tradeoff")
SMOKE = os.path.join(SAMPLES, "smoke.json")


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


class PlanCase(unittest.TestCase):
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


class Plan(PlanCase):
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

    def test_unreachable_bakes_the_most_accurate(self):
        """A tolerance below every prediction: the bake still writes the plan of the lowest
        predicted error, warns once naming it, and the report says it is out of reach. A
        8-voxel sphere under the cloud's medium and lights keeps the bake short."""
        vdb, out = self.path("sphere.vdb"), self.path("lit.vdb")
        run("sample", "sphere", "-o", vdb, "--res", "8", check=0)
        dry = self.dry(CLOUD, 0.0001, vdb)
        self.assertFalse(dry["reachable"])
        best = min(dry["candidates"], key=lambda c: c["predicted_error"])
        p = run("bake", vdb, "--scene", CLOUD, "-o", out, "--method", "auto", "--tolerance",
                "0.0001", "--json", check=0)
        lines = [l for l in p.stderr.splitlines() if "warning" in l]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn("out of reach", lines[0])
        self.assertIn(f"--method {best['method']} --quality {best['quality']}", lines[0])
        rep = json.loads(p.stdout)
        self.assertFalse(rep["plan"]["reachable"])
        self.assertEqual((rep["method"], rep["quality"]), (best["method"], best["quality"]))
        self.assertTrue(os.path.exists(out))

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



def measured(scene):
    """{(method, quality): (error, standard error)} of a calibration scene, as the planner's
    table holds it (scripts/gen_plan_table.py), or None."""
    for kind in ("calibration", "validation"):
        with open(os.path.join(TRADEOFF, f"{kind}.json")) as f:
            entry = json.load(f).get(scene)
        if entry:
            return {(r["method"], r["quality"]): (max(r["relrmse"], r["relrmse_se"], 1e-4),
                                                  r["relrmse_se"])
                    for r in entry["tradeoff"]["rows"]}
    return None


def log_ms_share(features):
    """log of the multiply scattered share ms / (ms + ss), floored at 1e-3: the error model's
    prior mean follows it (docs/planner.md "How it predicts")."""
    r = features["ms_to_ss"]
    return math.log(max(r / (1 + r), 1e-3))


def table_log_errors():
    """{(method, quality): [log(error / ms share) of every table scene]}."""
    out = {}
    for kind in ("calibration", "validation"):
        with open(os.path.join(TRADEOFF, f"{kind}.json")) as f:
            for entry in json.load(f).values():
                for r in entry["tradeoff"]["rows"]:
                    e = max(r["relrmse"], r["relrmse_se"], 1e-4)
                    out.setdefault((r["method"], r["quality"]), []).append(
                        math.log(e) - log_ms_share(entry["features"]))
    return out


class ErrorModel(PlanCase):
    """The bundled cloud sample is the calibration scene `cloud`."""

    def candidates(self, *extra):
        plan = self.dry(CLOUD, 0.1, *extra)
        return plan, {(c["method"], c["quality"]): c for c in plan["candidates"]}

    def test_calibration_scene_predicts_its_measurements(self):
        table = measured("cloud")
        self.assertIsNotNone(table)
        _, cands = self.candidates()
        for key, (err, se) in table.items():
            c = cands[key]
            noise = max(se / err, 0.01)
            # posterior at a measured point: its measurement, to within its noise
            self.assertLess(c["log_error_sd"], noise * 1.5, (key, c))
            if key[0] == "single":  # the single-scattering floor may bind (docs/planner.md)
                continue
            median = math.log(c["predicted_error"]) - c["log_error_sd"]
            self.assertLess(abs(median - math.log(err)), 3 * noise, (key, c, err))

    def test_plan_is_the_cheapest_measured_within_tolerance(self):
        table = measured("cloud")
        _, cands = self.candidates()
        checked = 0
        for e in (0.3, 0.15, 0.08, 0.04):
            # rows measured within a few standard errors of E could go either way
            if any(abs(err - e) < 3 * max(se, 0.01 * err) for err, se in table.values()):
                continue
            met = [k for k, (err, _) in table.items() if err <= e]
            plan = self.dry(CLOUD, e)
            checked += 1
            if not met:
                self.assertFalse(plan["reachable"], (e, plan["method"]))
                continue
            best = min(met, key=lambda k: cands[k]["predicted_seconds"])
            self.assertTrue(plan["reachable"], e)
            self.assertAlmostEqual(plan["predicted_seconds"], cands[best]["predicted_seconds"],
                                   msg=(e, best, plan["method"], plan["quality"]))
        self.assertGreaterEqual(checked, 3)

    def test_left_out_is_predicted_wider(self):
        inside, near = self.candidates()
        outside, far = self.candidates("--calibration-leave-out", "cloud")
        self.assertEqual(outside["calibration_scenes"], inside["calibration_scenes"] - 1)
        spread = table_log_errors()
        for key, c in near.items():
            sd_prior = math.sqrt(max(sum((v - sum(spread[key]) / len(spread[key])) ** 2
                                         for v in spread[key]) / (len(spread[key]) - 1), 0.01))
            self.assertGreater(far[key]["log_error_sd"], c["log_error_sd"], key)
            self.assertLessEqual(far[key]["log_error_sd"], sd_prior * (1 + 1e-9), key)

    def test_far_from_every_scene_is_the_prior(self):
        """Depth 200, albedo 0.05, g -0.9 on the cloud: at least 17 units squared from every
        table scene, so the posterior is the prior: mean and spread of the method's log
        errors over the ms share across the table (to the kernel's e^-8.5 share), times this
        scene's ms share."""
        plan, far = self.candidates("--density-scale", "auto:200", "--albedo", "0.05", "--g",
                                    "-0.9")
        share = log_ms_share(plan["features"])
        for key, logs in table_log_errors().items():
            mean = sum(logs) / len(logs)
            sd = math.sqrt(max(sum((v - mean) ** 2 for v in logs) / (len(logs) - 1), 0.01))
            c = far[key]
            self.assertAlmostEqual(c["log_error_sd"], sd, delta=0.02 * sd, msg=key)
            if key[0] != "single":
                self.assertAlmostEqual(math.log(c["predicted_error"]), mean + sd + share,
                                       delta=0.05, msg=key)

    def test_leave_out_flag_errors(self):
        out = self.path("lit.vdb")
        for args, needle in ((["--method", "auto", "--calibration-leave-out", "cloud"],
                              "--dry-run"),
                             (["--method", "auto", "--dry-run", "--calibration-leave-out",
                               "nosuch"], "nosuch")):
            p = run("bake", "--scene", CLOUD, "-o", out, *args)
            self.assertEqual(p.returncode, 2, (args, p.stderr))
            lines = [l for l in p.stderr.splitlines() if l.strip()]
            self.assertEqual(len(lines), 1, p.stderr)
            self.assertIn(needle, lines[0])
            self.assertFalse(os.path.exists(out))


if __name__ == "__main__":
    unittest.main()
