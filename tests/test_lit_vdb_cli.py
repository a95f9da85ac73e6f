#!/usr/bin/python3
"""The lit VDB renders as baked from its own grids (docs/lit-vdb.md): `render --mode baked`
takes single scattering from the stored optical depths to the lights (no light sweep) and
matches `--relight` (light grids swept at render time) for the solvers' bakes (the matrix of
samples, lights and g is test_lit_matrix_cli.py). Flags that change the lights or medium are
refused without --relight; `--store none` writes a file that renders the old way."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]

SIZE = "48x36"


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def sample(name):
    return os.path.join(SAMPLES, name)


class Base(unittest.TestCase):
    def setUp(self):
        root = os.environ.get("VDBSCATTER_TMP")
        if root:
            os.makedirs(root, exist_ok=True)
        self.tmp = tempfile.mkdtemp(prefix="lit_vdb_", dir=root)

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.tmp, name)

    def bake(self, volume, *extra, name="lit.vdb"):
        lit = self.path(name)
        run("bake", sample(volume + ".vdb"), "--scene", sample(volume + ".json"), "--quality", "low",
            "-o", lit, "-q", *extra, check=0)
        return lit

    def render(self, lit, out, *extra):
        p = run("render", lit, "-o", self.path(out), "--size", SIZE, "--json", *extra, check=0)
        return json.loads(p.stdout)

    def relrmse(self, a, b):
        p = run("compare", self.path(a), self.path(b), "--json", check=0)
        return json.loads(p.stdout)["relrmse"]


class FromGrids(Base):
    def test_baked_methods_match_relight(self):
        """The solvers' lit VDBs of the cloud under its sun and sky, g 0.85."""
        for method in ("pop", "fld", "svd"):
            with self.subTest(method=method):
                lit = self.bake("cloud", "--method", method)
                self.render(lit, "stored.exr")
                self.render(lit, "relit.exr", "--relight")
                self.assertLessEqual(self.relrmse("stored.exr", "relit.exr"), 0.01)

    def test_coarse_sky_grids_render_as_baked(self):
        """A sky dim enough (13% of the light) that its grids are coarser than the sun's
        (lightgrid.h): the stored sky depths carry their own spacing and render as relit."""
        with open(sample("cloud.json")) as f:
            scene = json.load(f)
        scene["volume"]["file"] = sample("cloud.vdb")
        for light in scene["lights"]:
            if light["type"] == "env":
                light["color"] = [0.02, 0.03, 0.05]
        dim = self.path("dim.json")
        with open(dim, "w") as f:
            json.dump(scene, f)
        lit = self.path("dim.vdb")
        p = run("bake", sample("cloud.vdb"), "--scene", dim, "--quality", "low", "--method", "single",
                "--s1-oversample", "2", "-o", lit, "-q", "--json", check=0)
        kinds = {k["kind"]: k for k in json.loads(p.stdout)["s1_grids_per_kind"]}
        self.assertEqual((kinds["sun"]["lights"], kinds["sky"]["lights"]), (1, 16))
        self.assertGreater(kinds["sky"]["spacing_min"], 1.5 * kinds["sun"]["spacing_max"])
        self.assertLess(kinds["sky"]["cells"], kinds["sun"]["cells"] * 16 / 3)
        self.render(lit, "stored.exr")
        self.render(lit, "relit.exr", "--relight", "--s1-oversample", "2")
        self.assertLessEqual(self.relrmse("stored.exr", "relit.exr"), 0.01)

    def test_store_none_renders_the_old_way(self):
        lit = self.bake("cloud", "--method", "single", "--store", "none")
        j = self.render(lit, "old.exr")
        self.assertEqual((j["s1"], j["relight"]), ("grid", False))
        self.render(lit, "relit.exr", "--relight")
        self.assertEqual(self.relrmse("old.exr", "relit.exr"), 0.0)
        stored = self.bake("cloud", "--method", "single", name="stored.vdb")
        self.assertGreater(os.path.getsize(stored), os.path.getsize(lit))

    def test_bake_reports_the_stored_grids(self):
        p = run("bake", sample("smoke.vdb"), "--scene", sample("smoke.json"), "--method", "single",
                "-o", self.path("s.vdb"), "-q", "--json", check=0)
        j = json.loads(p.stdout)
        self.assertEqual(j["store"], "lights")
        # smoke: a sun and a point light, no sky
        self.assertEqual([g for g in j["grids"] if "depth" in g], ["light_depth_000", "light_depth_001"])
        p = run("bake", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--method", "single",
                "-o", self.path("c.vdb"), "-q", "--json", check=0)
        j = json.loads(p.stdout)
        depths = [g for g in j["grids"] if "depth" in g]
        self.assertEqual(depths[0], "light_depth_000")
        self.assertEqual(depths[1:], [f"sky_depth_{k:04d}" for k in range(j["sky_directions"])])


class Refusals(Base):
    def test_changes_need_relight(self):
        lit = self.bake("cloud", "--method", "single")
        out = self.path("x.exr")
        for flags in (["--sun", "0,-1,0"], ["--point", "0,2,0"], ["--env", "1,1,1"], ["--albedo", "0.5"],
                      ["--g", "0.2"], ["--density-scale", "3"], ["--sky-directions", "8"],
                      ["--scene", sample("slab.json")]):
            with self.subTest(flags=flags):
                p = run("render", lit, "-o", out, "--size", "8x6", *flags)
                self.assertEqual(p.returncode, 2, p.stderr)
                self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
                self.assertIn("--relight", p.stderr)
                self.assertFalse(os.path.exists(out))
                run("render", lit, "-o", out, "--size", "8x6", "-q", "--relight", *flags, check=0)
                os.remove(out)
        # the baked scene itself, and a quality, are no change
        run("render", lit, "-o", out, "--size", "8x6", "-q", "--scene", sample("cloud.json"), check=0)
        run("render", lit, "-o", out, "--size", "8x6", "-q", "--quality", "medium", check=0)

    def test_s1_flags_and_relight_misuse(self):
        lit = self.bake("cloud", "--method", "single")
        out = self.path("x.exr")
        for args in ([lit, "--s1", "march"], [lit, "--relight", "--mode", "single"]):
            with self.subTest(args=args):
                p = run("render", *args, "-o", out, "--size", "8x6")
                self.assertEqual(p.returncode, 2, p.stderr)
                self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
                self.assertFalse(os.path.exists(out))
        p = run("render", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--relight", "-o", out,
                "--size", "8x6", check=0)
        self.assertIn("--relight applies to a lit VDB only", p.stderr)
        p = run("bake", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--store", "some",
                "-o", self.path("y.vdb"))
        self.assertEqual(p.returncode, 2)
        self.assertIn("--store", p.stderr)
        self.assertFalse(os.path.exists(self.path("y.vdb")))


if __name__ == "__main__":
    unittest.main(verbosity=2)
