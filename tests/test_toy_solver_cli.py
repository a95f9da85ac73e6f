#!/usr/bin/python3
"""A solver added from outside the library reaches every face of the tool: vdbscatter-toy is
the whole command line plus a test-only solver, "toy" (single scattering times a constant F,
option toy_factor / --toy-factor), registered in its main (tests/toy_solver.c) and touching no
library file. bake --help lists it and its option, the scene key and the flag set F, the lit
VDB holds F times single scattering, and the JSON report, the summary line and the metadata
carry the option. The shipping vdbscatter knows no toy."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
TOY = os.environ["VDBSCATTER_TOY"]
LIGHTS = ["--sun", "0.3,-1,0.2:2,2,2", "--env", "0.1,0.2,0.3", "--density-scale", "8",
          "--backend", "cpu", "--quality", "low"]


def run(exe, *args, code=0):
    p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, timeout=600)
    if p.returncode != code:
        raise AssertionError(f"{args}: exit {p.returncode} (expected {code}): {p.stderr}")
    return p


def radiance(path):
    grids, meta = vdb.readAll(path)
    g = {x.name: x for x in grids}
    values = {tuple(v.min): v.value for v in g["radiance"].citerOnValues()}
    ms = max(max(abs(c) for c in v.value) for v in g["ms"].citerOnValues())
    return values, ms, meta


class ToySolver(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="vdbscatter-toy-", dir=os.environ.get("VDBSCATTER_TMP"))
        self.src = self.path("cloud.vdb")
        run(EXE, "sample", "cloud", "--res", "24", "-o", self.src)

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_times(self, toy, single, factor):
        """Every voxel's radiance is factor times single scattering's (float rounding)."""
        self.assertEqual(set(toy), set(single))
        self.assertGreater(len(single), 100)
        worst = 0.0
        for k, s in single.items():
            for c in range(3):
                worst = max(worst, abs(toy[k][c] - factor * s[c]) / max(abs(factor * s[c]), 1e-30))
        self.assertLess(worst, 1e-6)

    def test_help_lists_the_option(self):
        out = run(TOY, "bake", "--help").stdout
        self.assertIn("toy                      single scattering times a constant", out)
        self.assertIn("--toy-factor F", out)
        self.assertIn("solver.toy_factor", out)
        shipped = run(EXE, "bake", "--help").stdout
        self.assertNotIn("toy", shipped)
        err = run(EXE, "bake", self.src, "-o", self.path("x.vdb"), "--method", "toy", *LIGHTS,
                  code=2).stderr
        self.assertIn("unknown method \"toy\"", err)
        self.assertFalse(os.path.exists(self.path("x.vdb")))

    def test_flag_report_and_metadata(self):
        single = self.path("single.vdb")
        run(TOY, "bake", self.src, "-o", single, "--method", "single", *LIGHTS, "-q")
        toy = self.path("toy.vdb")
        p = run(TOY, "bake", self.src, "-o", toy, "--method", "toy", "--toy-factor", "3",
                *LIGHTS, "--json")
        report = json.loads(p.stdout)
        self.assertEqual(report["method"], "toy")
        self.assertEqual(report["toy"]["factor"], 3)
        self.assertEqual(report["toy"]["voxels"], report["output_voxels"])
        self.assertEqual(report["scene"]["solver"]["toy_factor"], 3)
        s_values, _, _ = radiance(single)
        t_values, t_ms, meta = radiance(toy)
        self.assert_times(t_values, s_values, 3.0)
        self.assertEqual(t_ms, 0.0)
        self.assertEqual(meta["vdbscatter_method"], "toy")
        self.assertEqual(json.loads(meta["vdbscatter_scene"])["solver"]["toy_factor"], 3)
        # the summary line carries the solver's text block
        p = run(TOY, "bake", self.src, "-o", toy, "--method", "toy", "--toy-factor", "3", *LIGHTS)
        self.assertIn("toy: factor 3", p.stderr)

    def test_scene_key_and_preset(self):
        single = self.path("single.vdb")
        run(TOY, "bake", self.src, "-o", single, "--method", "single", *LIGHTS, "-q")
        s_values, _, _ = radiance(single)
        scene = self.path("toy.json")
        with open(scene, "w") as f:
            json.dump({"solver": {"method": "toy", "toy_factor": 1.5}}, f)
        toy = self.path("toy.vdb")
        run(TOY, "bake", self.src, "-o", toy, "--scene", scene, *LIGHTS, "-q")
        self.assert_times(radiance(toy)[0], s_values, 1.5)
        # unset, the option is its preset at the quality: 2 at low
        run(TOY, "bake", self.src, "-o", toy, "--method", "toy", *LIGHTS, "-q")
        self.assert_times(radiance(toy)[0], s_values, 2.0)

    def test_bad_values_name_the_option(self):
        for args, needle in ((["--toy-factor", "-1"], "--toy-factor"),
                             (["--toy-factor", "abc"], "--toy-factor"),
                             (["--toy-factor", "100"], "--toy-factor")):
            out = self.path("bad.vdb")
            err = run(TOY, "bake", self.src, "-o", out, "--method", "toy", *args, *LIGHTS,
                      code=2).stderr
            self.assertIn(needle, err)
            self.assertEqual(len(err.strip().splitlines()), 1, err)
            self.assertFalse(os.path.exists(out))
        scene = self.path("bad.json")
        for value, needle in (('"x"', "expected a number"), ("-2", "must be in [0, 100)"),
                              ("1", None)):
            with open(scene, "w") as f:
                f.write('{"solver": {"method": "toy", "toy_fctor": 1}}' if needle is None else
                        '{"solver": {"method": "toy", "toy_factor": %s}}' % value)
            err = run(TOY, "bake", self.src, "-o", self.path("bad.vdb"), "--scene", scene,
                      *LIGHTS, code=2).stderr
            self.assertEqual(len(err.strip().splitlines()), 1, err)
            if needle:
                self.assertIn("solver.toy_factor: " + needle, err)
            else:  # a typo: the did-you-mean names the toy's key
                self.assertIn('unknown key "toy_fctor" (did you mean "toy_factor"?)', err)


if __name__ == "__main__":
    unittest.main()
