#!/usr/bin/python3
"""The vdbscatter command as a pipeline meets it: help, flags, bad input (one line,
exit 2, no output file), every real file in the shared data folder, and output that
OpenVDB's own tools (vdb_print, pyopenvdb) read back."""
import json
import math
import os
import shutil
import subprocess
import tempfile
import unittest

import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
DATA = os.environ["VDBSCATTER_DATA_DIR"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
PI = math.pi


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def component_range(grid):
    """Smallest and largest component over the active values of a vec3 grid."""
    lo, hi = math.inf, -math.inf
    for item in grid.citerOnValues():
        lo = min(lo, *item.value)
        hi = max(hi, *item.value)
    return lo, hi


def sample(name):
    """A bundled sample: for the tests whose input is incidental (they run without the
    external data)."""
    return os.path.join(SAMPLES, name)


def data(name):
    """A file of the external test data; the calling test is skipped when there is none."""
    if not DATA:
        raise unittest.SkipTest(f"needs the external test data ({name})")
    return os.path.join(DATA, name)


class Base(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="vdbscatter-test-", dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_bad_input(self, args, needle, output="out.vdb"):
        """Exit 2, one line on stderr containing needle, no output file or temp file left."""
        p = run(*args)
        self.assertEqual(p.returncode, 2, f"{args}: {p.stderr}")
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        errors = [l for l in lines if "warning" not in l]
        self.assertEqual(len(errors), 1, f"{args}: expected one error line, got {p.stderr!r}")
        self.assertIn(needle.lower(), errors[0].lower(), f"{args}")
        if output:
            self.assertFalse(os.path.exists(self.path(output)), f"{args} left {output}")
        self.assertEqual([f for f in os.listdir(self.dir) if "tmp" in f], [], f"{args} left a temp file")
        return errors[0]

    def assert_s1_plus_ms(self, single, lit, inside=None):
        """radiance of `lit` is the single-only bake's S1 plus ms at every voxel to float
        rounding, ms >= 0; returns how many voxels (of `inside`, when given) have ms > 0."""
        s1 = values(single, "radiance")
        rad = values(lit, "radiance")
        ms = values(lit, "ms")
        self.assertEqual(s1.keys(), rad.keys())
        positive = 0
        for key, value in rad.items():
            m = ms.get(key, (0.0, 0.0, 0.0))
            for c in range(3):
                self.assertAlmostEqual(value[c], s1[key][c] + m[c], delta=1e-5 * max(1.0, value[c]))
                self.assertGreaterEqual(m[c], 0.0)
            positive += m[1] > 0.0 and (inside is None or key in inside)
        return positive

    def bake(self, src, *extra, out="lit.vdb"):
        """These tests' oracles are single scattering at quality medium (64 sky directions)
        unless a test names its method or quality: the bake's own defaults (svd at low) are
        checked in HelpAndFlags.test_defaults and test_stat_defaults_cli."""
        pinned = [] if "--method" in extra else ["--method", "single"]
        pinned += [] if "--quality" in extra else ["--quality", "medium"]
        out_path = self.path(out)
        p = run("bake", src, "-o", out_path, *pinned, *extra, check=0)
        return out_path, p


class HelpAndFlags(Base):
    def test_help_every_command(self):
        for cmd in ["bake", "info", "sample", "phase-svd"]:
            p = run(cmd, "--help", check=0)
            self.assertIn("usage: vdbscatter " + cmd, p.stdout)
        self.assertIn("commands:", run("--help", check=0).stdout)
        self.assertEqual(run().returncode, 2)
        self.assertEqual(run("frobnicate").returncode, 2)

    def test_unknown_and_malformed_flags(self):
        src = sample("cloud.vdb")
        out = self.path("out.vdb")
        base = ["bake", src, "-o", out, "--sun", "0,-1,0"]
        cases = [
            (base + ["--frobnicate"], "--frobnicate"),
            (base + ["--density-scale", "abc"], "--density-scale"),
            (base + ["--density-scale", "1e999"], "--density-scale"),
            (base + ["--density-scale=-1"], "density"),
            (base + ["--g", "nan"], "--g"),
            (base + ["--g", "1"], "g"),
            (base + ["--albedo", "1,2"], "--albedo"),
            (base + ["--albedo", "1.5"], "albedo"),
            (["bake", src, "-o", out, "--sun", "1,2"], "--sun"),
            (["bake", src, "-o", out, "--sun", "0,-1,0:1,x,1"], "--sun"),
            (["bake", src, "-o", out, "--sun", "0,0,0"], "sun"),
            (["bake", src, "-o", out, "--point", "1,2,3:"], "--point"),
            (["bake", src, "-o", out], "light"),
            (base + ["--backend", "tpu"], "--backend"),
            (base + ["--quality", "extreme"], "quality"),
            (base + ["--method", "inets"], "inets"),
            (base + ["--method", "inet", "--inet-particles", "0"], "--inet-particles"),
            (base + ["--method", "inet", "--inet-directions", "1"], "--inet-directions"),
            (base + ["--method", "inet", "--inet-residual", "x"], "--inet-residual"),
            (base + ["--method", "svd", "--svd-directions", "1"], "--svd-directions"),
            (base + ["--method", "svd", "--svd-terms", "0"], "--svd-terms"),
            (base + ["--method", "svd", "--svd-terms", "x"], "--svd-terms"),
            (base + ["--method", "svd", "--svd-directions", "16", "--svd-terms", "20"], "svd_terms"),
            (base + ["--method", "svd", "--svd-res", "1"], "--svd-res"),
            (base + ["--method", "svd", "--svd-iterations", "0"], "--svd-iterations"),
            (base + ["--method", "svd", "--residual", "0"], "--residual"),
            (base + ["--method", "svd", "--residual", "nan"], "--residual"),
            (base + ["--method", "svd", "--residual", "1.5"], "--residual"),
            (base + ["--method", "svd", "--svd-scheme", "bogus"], "--svd-scheme"),
            (base + ["--method", "pop", "--keep-state"], "--keep-state"),
            (base + ["--method", "pop", "--warm-start", src], "--warm-start"),
            (base + ["--method", "fld", "--warm-start", src], "--warm-start"),  # no state in it
            (base + ["--method", "svd", "--warm-start", src], "--warm-start"),
            (base + ["--method", "svd", "--warm-start", self.path("missing.vdb")], "missing.vdb"),
            (base + ["--method", "pop", "--pop-res", "1"], "--pop-res"),
            (base + ["--method", "pop", "--pop-res", "8x"], "--pop-res"),
            (base + ["--method", "pop", "--pop-ordinates", "0"], "--pop-ordinates"),
            (base + ["--method", "pop", "--pop-decay", "fast"], "--pop-decay"),
            (base + ["--method", "pop", "--pop-tally", "voxel"], "--pop-tally"),
            (base + ["--method", "fld", "--fld-res", "1"], "--fld-res"),
            (base + ["--method", "fld", "--fld-res", "x"], "--fld-res"),
            (base + ["--method", "fld", "--fld-limiter", "maybe"], "--fld-limiter"),
            (base + ["--method", "fld", "--fld-p1", "1"], "--fld-p1"),
            (base + ["--method", "pop", "--pop-iterations", "0"], "--pop-iterations"),
            (base + ["--method", "pop", "--pop-decay", "paper", "--g", "-0.3"], "--pop-decay"),
            (base + ["--method", "pop", "--pop-radial", "7"], "--pop-radial"),
            (base + ["--method", "pop", "--pop-radial", "0"], "--pop-radial"),
            (base + ["--method", "pop", "--pop-importance"], "camera"),
            (base + ["--camera", "0,0,4:0,0,0"], "--camera"),
            (base + ["--camera", "0,0,4:0,0,4:35"], "--camera"),
            (base + ["--camera", "0,0,4:0,0,0:180"], "--camera"),
            (base + ["--s1", "cone"], "--s1"),
            (base + ["--s1-oversample", "0"], "--s1-oversample"),
            (base + ["--s1-oversample", "2.5"], "--s1-oversample"),
            (base + ["--scene"], "--scene"),
            (base + ["--half=1"], "--half"),
            (["bake", src, "--sun", "0,-1,0"], "-o"),
            (["sample", "cloud", "-o", out, "--res", "0"], "--res"),
            (["sample", "cloud", "-o", out, "--res", "12x"], "--res"),
            (["sample", "teapot", "-o", out], "teapot"),
            (["phase-svd", "--g", "0.5"], "--directions"),
            (["phase-svd", "--g", "1", "--directions", "8"], "--g"),
            (["phase-svd", "--g", "0.5", "--directions", "1"], "--directions"),
            (["phase-svd", "--g", "0.5", "--directions", "8", "--delta-m", "maybe"], "--delta-m"),
        ]
        for args, needle in cases:
            with self.subTest(args=args):
                self.assert_bad_input(args, needle)

    def test_first_hour(self):
        """What a newcomer meets first: defaults, the order and wording of errors, warnings for
        scenes that are almost certainly a mistake, and the density-scale helpers."""
        cloud = os.path.join(SAMPLES, "cloud.vdb")
        out = self.path("out.vdb")
        # Input, grid and flag errors come before "no light" (none is given here).
        self.assert_bad_input(["bake", self.path("missing.vdb"), "-o", out], "missing.vdb")
        self.assert_bad_input(["bake", cloud, "-o", out, "--grid", "dens"], "no grid named")
        line = self.assert_bad_input(["bake", cloud, "-o", out, "--quality", "hgh"], "--quality")
        self.assertIn('did you mean "high"?', line)
        self.assert_bad_input(["bake", cloud, "-o", out], "no light at all")
        # A flag's error names the flag, not the scene key it sets.
        for flag, value in [("--g", "1"), ("--albedo", "1.5"), ("--sun", "0,-1,0:-1"),
                            ("--point", "0,0,0:1,-2,1"), ("--density-scale", "-1"),
                            ("--method", "fdl"), ("--quality", "hgh")]:
            extra = [] if flag in ("--sun", "--point") else ["--sun", "0,-1,0"]
            line = self.assert_bad_input(["bake", cloud, "-o", out, *extra, flag, value], flag)
            self.assertTrue(line.startswith(f"vdbscatter bake: {flag}: "), line)
        # Typos get the nearest flag, scene key or method.
        line = self.assert_bad_input(["bake", cloud, "-o", out, "--densty-scale", "3"],
                                     "--densty-scale")
        self.assertIn("did you mean --density-scale?", line)
        line = self.assert_bad_input(["bake", cloud, "-o", out, "--sun", "0,-1,0", "--method",
                                      "ient"], "--method")
        self.assertIn("single, pop, fld, svd, inet", line)
        sp = self.path("typo.json")
        with open(sp, "w") as f:
            json.dump({"volume": {"albdo": 0.9}}, f)
        line = self.assert_bad_input(["bake", cloud, "--scene", sp, "-o", out], "albdo")
        self.assertIn('did you mean "albedo"?', line)
        self.assertIn("file, grid, density_scale, albedo, g", line)
        # Malformed density targets, in bake and in info.
        for value in ["auto:", "auto:0", "auto:-3", "auto:x", "auto:inf"]:
            self.assert_bad_input(["bake", cloud, "-o", out, "--sun", "0,-1,0", "--density-scale",
                                   value], "--density-scale")
        for value in ["0", "-1", "x", "nan"]:
            self.assert_bad_input(["info", cloud, "--target-depth", value], "--target-depth",
                                  output=None)
        # A lit VDB is OpenVDB or NanoVDB: another extension is refused, and nothing is written.
        self.assert_bad_input(["bake", cloud, "-o", self.path("x.vdb.txt"), "--sun", "0,-1,0"],
                              "-o: expected .vdb or .nvdb", output="x.vdb.txt")
        help_text = run("bake", "--help", check=0).stdout
        self.assertNotIn("%%", help_text)
        self.assertIn("--inet-particles N", help_text)

        # The default bake is svd at low, in the report and the metadata.
        p = run("bake", "--scene", os.path.join(SAMPLES, "cloud.json"), "-o", out, "--json",
                check=0)
        self.assertEqual(p.returncode, 0, p.stderr)
        report = json.loads(p.stdout)
        self.assertEqual((report["method"], report["quality"]), ("svd", "low"))
        meta = vdb.readAllGridMetadata(out)[0]
        self.assertEqual((meta["vdbscatter_method"], meta["vdbscatter_quality"]), ("svd", "low"))
        self.assertEqual(p.stderr.count("warning"), 0, p.stderr)

        # auto:TAU is the scale info --target-depth prints, in the report and the metadata.
        info = json.loads(run("info", cloud, "--target-depth", "10", "--json", check=0).stdout)
        fitted = info["optical_thickness"]["density_scale_for_target"]
        p = run("bake", cloud, "-o", out, "--sun", "0,-1,0", "--density-scale", "auto:10",
                "--json", "-q", check=0)
        report = json.loads(p.stdout)
        self.assertAlmostEqual(report["density_scale"], fitted, delta=1e-9 * fitted)
        self.assertAlmostEqual(report["mean_optical_depth"], 10.0, delta=1e-6)
        self.assertEqual(report["scene"]["volume"]["density_scale"], report["density_scale"])
        meta = vdb.readAllGridMetadata(out)[0]
        self.assertAlmostEqual(float(meta["vdbscatter_density_scale"]), fitted,
                               delta=1e-9 * fitted)
        # info's world box: the index box's outer faces through the grid's own transform.
        g = info["grids"][0]
        xf = vdb.read(cloud, "density").transform
        lo = xf.indexToWorld(tuple(v - 0.5 for v in g["bbox_min"]))
        hi = xf.indexToWorld(tuple(v + 0.5 for v in g["bbox_max"]))
        for a in range(3):
            self.assertAlmostEqual(g["world_min"][a], lo[a], places=9)
            self.assertAlmostEqual(g["world_max"][a], hi[a], places=9)

        # Almost certainly a mistake: one warning line each, exit 0, the output is written.
        cases = [
            (["--sun", "0,-1,0:0"], "is zero"),
            (["--sun", "0,-1,0", "--density-scale", "0"], "density scale 0"),
            (["--sun", "0,-1,0", "--density-scale", "0.01"], "nearly invisible"),
            (["--sun", "0,-1,0", "--density-scale", "1e6"], "only its skin"),
            (["--sun", "0,-1,0", "--density-scale", "20", "--albedo", "0.99", "--method",
              "single"], "leaves out multiple scattering"),
        ]
        for extra, needle in cases:
            with self.subTest(extra=extra):
                os.path.exists(out) and os.remove(out)
                p = run("bake", cloud, "-o", out, "--quality", "low", *extra, check=0)
                self.assertEqual(p.returncode, 0, p.stderr)
                self.assertTrue(os.path.exists(out))
                warnings = [l for l in p.stderr.splitlines() if "warning" in l]
                self.assertTrue(any(needle in l for l in warnings), p.stderr)
        p = run("bake", cloud, "-o", out, "--quality", "low", "--sun", "0,-1,0",
                "--density-scale", "20", "--albedo", "0.3", "--method", "single", check=0)
        self.assertNotIn("warning", p.stderr)  # smoke-like: single scattering dominates

    def test_flag_equals_form(self):
        a, _ = self.bake(sample("cloud.vdb"), "--sun", "0,-1,0:2,2,2", "--density-scale", "3", out="a.vdb")
        b, _ = self.bake(sample("cloud.vdb"), "--sun=0,-1,0:2,2,2", "--density-scale=3", out="b.vdb")
        ga = vdb.read(a, "radiance")
        gb = vdb.read(b, "radiance")
        self.assertEqual(ga.activeVoxelCount(), gb.activeVoxelCount())
        acc_b = gb.getConstAccessor()
        for value in list(ga.citerOnValues())[:2000]:
            self.assertEqual(acc_b.getValue(value.min), value.value)

    def test_scene_file_and_overrides(self):
        scene = {
            "volume": {"file": sample("cloud.vdb"), "density_scale": 2.0, "albedo": 0.9},
            "lights": [{"type": "sun", "direction": [0, -1, 0], "irradiance": [1, 1, 1]}],
        }
        sp = self.path("scene.json")
        with open(sp, "w") as f:
            json.dump(scene, f)
        out = self.path("lit.vdb")
        p = run("bake", "--scene", sp, "-o", out, "--json", check=0)
        report = json.loads(p.stdout)
        self.assertEqual(report["scene"]["volume"]["density_scale"], 2.0)
        p = run("bake", "--scene", sp, "-o", out, "--density-scale", "5", "--env", "0.1,0.1,0.1", "--json", check=0)
        report = json.loads(p.stdout)
        self.assertEqual(report["scene"]["volume"]["density_scale"], 5.0)
        self.assertEqual([l["type"] for l in report["scene"]["lights"]], ["env"])
        with open(sp, "w") as f:
            f.write('{"volume": {"density_scale": 2.0,}')
        self.assert_bad_input(["bake", "--scene", sp, "-o", self.path("lit2.vdb")], "scene",
                              output="lit2.vdb")
        with open(sp, "w") as f:
            json.dump({"volume": {"densty_scale": 1}}, f)
        self.assert_bad_input(["bake", sample("cloud.vdb"), "--scene", sp, "-o", self.path("x.vdb"), "--sun", "0,-1,0"], "densty_scale", output="x.vdb")


class BadFiles(Base):
    def bake_args(self, src, *extra):
        return ["bake", src, "-o", self.path("out.vdb"), "--sun", "0,-1,0", *extra]

    def test_input_path_too_long(self):
        # The path goes into the scene the bake records; one that does not fit is refused
        # before anything is read or written.
        long_path = os.path.join(self.dir, "d" * 250, *["e" * 250] * 16, "in.vdb")
        self.assert_bad_input(self.bake_args(long_path), "IN.vdb: the path is too long")

    def test_missing_foreign_truncated(self):
        self.assert_bad_input(self.bake_args(self.path("nope.vdb")), "nope.vdb")
        text = self.path("notes.vdb")
        with open(text, "w") as f:
            f.write("this is not a volume\n" * 100)
        self.assert_bad_input(self.bake_args(text), "notes.vdb")
        src = data("wdas_cloud_sixteenth.vdb")
        for fraction in [0.02, 0.5, 0.97]:
            cut = self.path(f"cut{fraction}.vdb")
            with open(src, "rb") as f:
                blob = f.read()
            with open(cut, "wb") as f:
                f.write(blob[: int(len(blob) * fraction)])
            with self.subTest(fraction=fraction):
                self.assert_bad_input(self.bake_args(cut), "cut")

    def test_grid_problems(self):
        line = self.assert_bad_input(self.bake_args(data("usd_smoke_000001.vdb")), "empty")
        self.assertIn("density", line)
        line = self.assert_bad_input(self.bake_args(data("usd_densityAndHeat.vdb"), "--grid", "smoke"), "smoke")
        self.assertIn("heat", line)  # lists the grids that exist
        self.assert_bad_input(self.bake_args(data("usd_smoke_000001.vdb"), "--grid", "obstacles"), "int32")
        self.assert_bad_input(self.bake_args(data("usd_smoke_000001.vdb"), "--grid", "velocity"), "vec3s")
        self.assert_bad_input(self.bake_args(data("openvdb_sphere_ls.vdb")), "--from-levelset")
        self.assert_bad_input(self.bake_args(data("arnold_3density_grids.vdb"), "--grid", "density@3"), "density")
        self.assert_bad_input(self.bake_args(data("arnold_3density_grids.vdb"), "--grid", "density@x"), "density@x")

    def test_bad_values(self):
        for name, bad, needle in [("nan", float("nan"), "nan"), ("neg", -0.5, "negative"), ("inf", float("inf"), "inf")]:
            grid = vdb.FloatGrid()
            grid.name = "density"
            acc = grid.getAccessor()
            for i in range(4):
                for j in range(4):
                    for k in range(4):
                        acc.setValueOn((i, j, k), 0.5)
            acc.setValueOn((2, 1, 3), bad)
            acc.setValueOn((3, 3, 3), bad)
            src = self.path(f"{name}.vdb")
            vdb.write(src, grids=[grid])
            with self.subTest(name=name):
                line = self.assert_bad_input(self.bake_args(src), needle)
                self.assertIn("2", line)  # how many

    def test_output_equal_to_input(self):
        src = self.path("in.vdb")
        shutil.copy(sample("cloud.vdb"), src)
        before = os.path.getsize(src)
        p = run("bake", src, "-o", src, "--sun", "0,-1,0")
        self.assertEqual(p.returncode, 2)
        self.assertEqual(os.path.getsize(src), before)
        self.assertEqual(len(p.stderr.strip().splitlines()), 1)

    def test_unwritable_outputs(self):
        src = sample("cloud.vdb")
        sub = self.path("sub")
        os.mkdir(sub)
        self.assert_bad_input(["bake", src, "-o", sub, "--sun", "0,-1,0"], "directory", output=None)
        self.assert_bad_input(["bake", src, "-o", self.path("missing/x.vdb"), "--sun", "0,-1,0"],
                              "does not exist", output=None)
        self.assert_bad_input(["sample", "cube", "-o", sub], "directory", output=None)
        self.assertEqual(os.listdir(sub), [])


class RealFiles(Base):
    def read_meta(self, path):
        return vdb.readAllGridMetadata(path)

    def check_lit(self, path, src_voxels=None):
        names = {g.name for g in vdb.readAllGridMetadata(path)}
        self.assertTrue({"density", "radiance", "ms", "ms_l1x", "ms_l1y", "ms_l1z"} <= names, names)
        self.assertEqual(subprocess.run(["vdb_print", path], capture_output=True).returncode, 0)
        radiance = vdb.read(path, "radiance")
        density = vdb.read(path, "density")
        if src_voxels is not None:
            self.assertEqual(density.activeVoxelCount(), src_voxels)
        self.assertGreater(radiance.activeVoxelCount(), density.activeVoxelCount())
        lo, hi = component_range(radiance)
        self.assertTrue(math.isfinite(hi) and lo >= 0, (lo, hi))
        return radiance

    def test_clouds_and_smokes(self):
        for name, scale in [("wdas_cloud_sixteenth.vdb", 1.0), ("openvdb_smoke1.vdb", 2.0),
                            ("usd_smoke_000002.vdb", 2.0), ("usd_densityAndHeat.vdb", 1.0),
                            ("plasma_blender_fluid_0001_multigrid.vdb", 1.0)]:
            with self.subTest(name=name):
                out, p = self.bake(data(name), "--sun", "0.3,-1,0.2:3,3,3", "--density-scale", scale, "-q", out=name)
                self.assertEqual(p.stderr, "")
                r = self.check_lit(out)
                # S1 never exceeds the unattenuated light: E / 4pi
                self.assertLessEqual(component_range(r)[1], 3.0 / (4 * PI) * (1 + 1e-6))
                meta = vdb.readAllGridMetadata(out)[0]
                scene = json.loads(meta["vdbscatter_scene"])
                self.assertEqual(scene["volume"]["density_scale"], scale)
                self.assertEqual(meta["vdbscatter_method"], "single")

    def test_double_grid(self):
        out, _ = self.bake(data("smoke_double_128x64x64.vdb"), "--sun", "0,-1,0", "--quality", "low", "-q")
        self.check_lit(out, src_voxels=524288)

    def test_duplicate_names(self):
        out, p = self.bake(data("arnold_3density_grids.vdb"), "--sun", "0,-1,0", out="a0.vdb")
        self.assertIn("density@1", p.stderr)
        self.assertIn("warning", p.stderr)
        first = vdb.read(out, "density")
        out1, _ = self.bake(data("arnold_3density_grids.vdb"), "--sun", "0,-1,0", "--grid", "density@1", "-q", out="a1.vdb")
        second = vdb.read(out1, "density")
        a = sorted((v.min, v.value) for v in first.citerOnValues())
        b = sorted((v.min, v.value) for v in second.citerOnValues())
        self.assertNotEqual(a, b)

    def test_background_and_tiles(self):
        out, p = self.bake(data("vpt_box.vdb"), "--sun", "0,-1,0", "--density-scale", "2")
        self.assertIn("background", p.stderr)
        density = vdb.read(out, "density")
        self.assertEqual(density.background, 0.0)
        self.assertEqual(density.activeVoxelCount(), 9261)
        radiance = vdb.read(out, "radiance")
        self.assertEqual(radiance.activeVoxelCount(), 23 ** 3)  # 21^3 dilated by one
        # top face of a homogeneous box under a normal sun: half a voxel of depth
        h = density.transform.voxelSize()[1]
        top = radiance.getConstAccessor().getValue((0, 10, 0))
        self.assertAlmostEqual(top[0], math.exp(-0.5 * h * 2.0) / (4 * PI), delta=1e-3 * top[0])

    def test_rotated_transform_carried(self):
        src = data("vpt_dragon_with_xform.vdb")
        out, _ = self.bake(src, "--sun", "0,-1,0", "-q")
        gin = vdb.read(src, "density")
        for grid in ["density", "radiance"]:
            g = vdb.read(out, grid)
            for ijk in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (-70, 99, 31)]:
                a = gin.transform.indexToWorld(ijk)
                b = g.transform.indexToWorld(ijk)
                for x, y in zip(a, b):
                    self.assertAlmostEqual(x, y, places=12)

    def test_levelset_conversion(self):
        out, _ = self.bake(data("openvdb_sphere_ls.vdb"), "--from-levelset", "--sun", "0,-1,0", "-q")
        d = vdb.read(out, "density")
        lo, hi = d.evalMinMax()
        self.assertGreaterEqual(lo, 0.0)
        self.assertLessEqual(hi, 1.0)
        self.assertGreater(d.activeVoxelCount(), 100000)

    def test_half_report_and_json(self):
        rp = self.path("report.json")
        out, p = self.bake(data("usd_densityAndHeat.vdb"), "--sun", "0,-1,0:1e6,1e6,1e6", "--half",
                           "--report", rp, "--json")
        self.assertIn("65504", p.stderr)
        report = json.loads(p.stdout)
        with open(rp) as f:
            self.assertEqual(json.load(f)["grids"], report["grids"])
        for stage in ["load", "solve", "write", "total"]:
            self.assertGreaterEqual(report["seconds"][stage], 0.0)
        self.assertEqual(report["backend"], "cpu")
        r = vdb.read(out, "radiance")
        self.assertLessEqual(component_range(r)[1], 65504.0)


class EnvMaps(Base):
    def test_bake_with_the_test_sky(self):
        """sample sky writes the bundled test map's kind; bake --env FILE[:SCALE] lights with it,
        the scale scaling S1 exactly; render reads the map the lit VDB was baked with."""
        sky = self.path("sky.exr")
        run("sample", "sky", "-o", sky, "--res", "32", check=0)
        src = os.path.join(SAMPLES, "cloud.vdb")
        common = ["--density-scale", "20", "--quality", "low", "--json", "-q"]
        one, p = self.bake(src, "--env", sky, *common, out="one.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        half, p = self.bake(src, "--env", sky + ":0.5", *common, out="half.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        a = {tuple(i.min): i.value for i in vdb.read(one, "radiance").citerOnValues()}
        b = {tuple(i.min): i.value for i in vdb.read(half, "radiance").citerOnValues()}
        self.assertGreater(max(max(v) for v in a.values()), 0.0)
        for key, v in a.items():
            for c in range(3):
                self.assertAlmostEqual(b[key][c], 0.5 * v[c], delta=1e-6 * max(v[c], 1e-30))
        p = run("render", one, "-o", self.path("r.exr"), "--size", "8x6", "-q")
        self.assertEqual(p.returncode, 0, p.stderr)

    def test_bad_maps(self):
        sky = self.path("sky.exr")
        run("sample", "sky", "-o", sky, "--res", "8", check=0)
        square = self.path("square.exr")  # an image that is not 2:1
        run("render", os.path.join(SAMPLES, "cube.vdb"), "-o", square, "--size", "8x8", "--sun", "0,-1,0",
            "-q", check=0)
        png = self.path("sky.png")
        run("render", os.path.join(SAMPLES, "cube.vdb"), "-o", png, "--size", "16x8", "--sun", "0,-1,0",
            "-q", check=0)
        src = os.path.join(SAMPLES, "cloud.vdb")
        for env, needle in [(square, "twice as wide"), (png, "not an OpenEXR or Radiance HDR"),
                            (self.path("missing.exr"), "missing.exr"), (sky + ":-1", "scale")]:
            with self.subTest(env=env):
                self.assert_bad_input(["bake", src, "-o", self.path("out.vdb"), "--env", env], needle)

    def test_fuzz_findings_on_the_command_line(self):
        """The inputs kept from fuzzing (fuzz/regressions/), through the command line: one line
        naming the problem, exit 2, no output. A Radiance HDR cut inside a run-length scanline
        (stb_image looped forever on it), a scene file with a 25 kB key and a --grid of 1 kB
        (each once filled the whole message), a VDB whose grid metadata claims a 2 GB string
        (OpenVDB allocated and zero-filled it first)."""
        fuzz = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fuzz", "regressions")
        src = os.path.join(SAMPLES, "cloud.vdb")
        out = ["-o", self.path("out.vdb"), "--sun", "0,-1,0", "-q"]
        cases = [
            (["bake", src, *out, "--env", os.path.join(fuzz, "hdr", "truncated_rle_scanline.hdr")],
             "scanline"),
            (["bake", src, *out, "--scene", os.path.join(fuzz, "scene", "long_unknown_key.json")],
             "unknown key"),
            (["bake", src, *out, "--grid", "d" * 1000], "grid"),
            (["bake", os.path.join(fuzz, "vdb", "grid_metadata_2gb_string.vdb"), *out], "metadata"),
        ]
        for args, needle in cases:
            with self.subTest(args=args[:3]):
                line = self.assert_bad_input(args, needle)
                self.assertLess(len(line), 700, line)


class LightGrids(Base):
    def test_s1_grid_against_march(self):
        """bake with light grids (the default; --s1 grid): reported and recorded, and within 1%
        relative RMSE of --s1 march (over voxels above 1e-3 of the maximum) on the cloud sample,
        sun + point + sky; the report gives the grids' sizes and the stages' times."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        lights = ["--density-scale", "20", "--sun", "0.3,-1,0.2", "--point", "0,0.2,0:2,2,2",
                  "--env", "0.2,0.3,0.5", "--quality", "low", "--json"]
        grid, p = self.bake(src, *lights, out="grid.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        report = json.loads(p.stdout)
        self.assertEqual(report["s1"], "grid")
        self.assertEqual(report["s1_oversample"], 1)  # the quality's: 1 at low
        lg = report["light_grids"]
        self.assertGreater(lg["columns"], lg["columns_empty"])
        self.assertGreater(lg["columns_empty"], 0)
        self.assertGreater(lg["cells"], lg["samples_stored"])
        self.assertGreater(lg["samples_stored"], 0)
        for stage in ["s1_sweep", "s1_lookup"]:
            self.assertGreaterEqual(report["seconds"][stage], 0.0)
        self.assertLessEqual(report["seconds"]["s1_sweep"] + report["seconds"]["s1_lookup"],
                             report["seconds"]["solve"])
        march, p = self.bake(src, "--s1", "march", *lights, out="march.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(json.loads(p.stdout)["s1"], "march")
        self.assertNotIn("light_grids", json.loads(p.stdout))
        g = {tuple(i.min): i.value for i in vdb.read(grid, "radiance").citerOnValues()}
        m = {tuple(i.min): i.value for i in vdb.read(march, "radiance").citerOnValues()}
        self.assertEqual(g.keys(), m.keys())
        peak = max(max(v) for v in m.values())
        num = den = 0.0
        for key, want in m.items():
            for c in range(3):
                if want[c] > 1e-3 * peak:
                    num += (g[key][c] - want[c]) ** 2
                    den += want[c] ** 2
        self.assertLessEqual(math.sqrt(num / den), 0.01)
        meta = vdb.readAllGridMetadata(grid)[0]
        self.assertEqual(meta["vdbscatter_s1"], "grid")


def hg(g, mu):
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * mu) ** 1.5)


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def toward(grid, key, eye):
    """Unit direction from the centre of voxel key to the world point eye."""
    w = grid.transform.indexToWorld(key)
    return unit([eye[a] - w[a] for a in range(3)])


def values(path, name):
    return {tuple(i.min): i.value for i in vdb.read(path, name).citerOnValues()}


class RadianceView(Base):
    """radiance_view: S(x, wo) toward the camera, written only when there is a camera."""

    EYE = [0.5, 0.8, 4.0]
    CAMERA = "0.5,0.8,4:0,0,0:35"

    def test_single_is_the_phase_toward_the_camera(self):
        """One sun, g 0.7: radiance_view = 4 pi radiance HG(d . wo) at every voxel (radiance
        is E T / 4 pi), to float rounding; without a camera the grid is absent."""
        src = os.path.join(SAMPLES, "sphere.vdb")
        lights = ["--sun", "0.3,-1,0.2:2,2,2", "--g", "0.7", "--density-scale", "3"]
        out, p = self.bake(src, *lights, "--camera", self.CAMERA, "--json")
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("radiance_view", json.loads(p.stdout)["grids"])
        rad = values(out, "radiance")
        grid = vdb.read(out, "radiance_view")
        d = unit([0.3, -1, 0.2])
        checked = 0
        for it in grid.citerOnValues():
            key = tuple(it.min)
            mu = sum(a * b for a, b in zip(d, toward(grid, key, self.EYE)))
            for c in range(3):
                want = 4 * math.pi * rad[key][c] * hg(0.7, mu)
                self.assertAlmostEqual(it.value[c], want, delta=2e-6 * max(want, 1e-3))
            checked += rad[key][0] > 1e-3
        self.assertGreater(checked, 1000)
        plain, p = self.bake(src, *lights, out="plain.vdb")
        self.assertNotIn("radiance_view", [g.name for g in vdb.readAllGridMetadata(plain)])

    def test_pop_adds_the_reconstructed_ms(self):
        """POP on the cloud (sun + sky, g 0.85): radiance_view minus the single-only bake's is
        the docs/lit-vdb.md reconstruction 4 pi ms HG(wo . n, b) of the ms grids, per channel, to
        float rounding; with g 0 it equals radiance (isotropic: no moment, HG = 1/4pi)."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        for g in [0.85, 0.0]:
            lights = ["--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--g", str(g),
                      "--density-scale", "20", "--albedo", "0.99", "--quality", "low",
                      "--camera", self.CAMERA]
            single, _ = self.bake(src, *lights, out="single.vdb")
            pop, p = self.bake(src, *lights, "--method", "pop", out="pop.vdb")
            self.assertEqual(p.returncode, 0, p.stderr)
            grid = vdb.read(pop, "radiance_view")
            s1 = values(single, "radiance_view")
            ms = values(pop, "ms")
            l1 = [values(pop, "ms_l1" + a) for a in "xyz"]
            rad = values(pop, "radiance")
            lit = 0
            for it in grid.citerOnValues():
                key = tuple(it.min)
                wo = toward(grid, key, self.EYE)
                for c in range(3):
                    if g == 0.0:
                        self.assertAlmostEqual(it.value[c], rad[key][c], delta=2e-6 * max(rad[key][c], 1e-3))
                        continue
                    m = ms.get(key, (0, 0, 0))[c]
                    v = [l1[a].get(key, (0, 0, 0))[c] for a in range(3)]
                    length = math.sqrt(sum(x * x for x in v))
                    if m <= 0:
                        want = 0.0
                    elif length == 0:
                        want = m
                    else:
                        b = min(length / (3 * m), 0.999)
                        mu = sum(x * y for x, y in zip(v, wo)) / length
                        want = 4 * math.pi * m * hg(b, mu)
                    got = it.value[c] - s1[key][c]
                    self.assertAlmostEqual(got, want, delta=1e-5 * max(it.value[c], 1e-2))
                lit += ms.get(key, (0, 0, 0))[1] > 0
            self.assertGreater(lit, 1000)

    def test_march_agrees_with_the_light_grids(self):
        """--s1 march takes radiance_view's S1 from light grids (the march has no per-light
        output): g 0 makes it the fluence / 4pi, within 1% RMS of the march's radiance."""
        src = os.path.join(SAMPLES, "sphere.vdb")
        out, p = self.bake(src, "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--density-scale",
                           "3", "--s1", "march", "--quality", "low", "--camera", self.CAMERA)
        self.assertEqual(p.returncode, 0, p.stderr)
        rad = values(out, "radiance")
        view = values(out, "radiance_view")
        num = den = 0.0
        for key, want in rad.items():
            num += sum((view[key][c] - want[c]) ** 2 for c in range(3))
            den += sum(w * w for w in want)
        self.assertLessEqual(math.sqrt(num / den), 0.01)


class Fld(Base):
    def test_fld_adds_ms_and_balances_energy(self):
        """bake --method fld on the cloud sample (a sun and a constant sky, albedo 0.99, g 0.85)
        at --quality low: radiance is the single-scatter bake's S1 plus ms to float rounding,
        ms is non-negative and positive inside the cloud; the report's absorbed + leaked power
        equals the source power to 1e-6 (the last solve runs until the residual's sum is 1e-7
        of the source's, whatever the quality's tolerance), the source is at least sigma_s 4 pi
        S1 summed over the voxels times their volume (the point rule, which undercounts the
        optically thick voxels here; +0.3% measured) and within 2% of it, and the resolution
        comes from the medium: the mean sigma_tr = 20 density (1 - 0.99 g) over the voxels with
        density (2.15 per unit at g 0.85, 13.6 at g 0) times the 1.5-unit extent,
        one cell per transport path at low, at least 12 cells: 12 and then 21 at g 0."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        lights = ["--density-scale", "20", "--albedo", "0.99", "--g", "0.85", "--sun",
                  "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--quality", "low", "--json"]
        single, _ = self.bake(src, *lights, out="single.vdb")
        fld, p = self.bake(src, *lights, "--method", "fld", out="fld.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        report = json.loads(p.stdout)
        stats = report["fld"]
        self.assertEqual(stats["resolution"], 12)
        self.assertLessEqual(stats["residual"], 1e-4)
        self.assertAlmostEqual(stats["absorbed"] + stats["leaked"], stats["source"],
                               delta=1e-6 * stats["source"])
        for stage in ["fld_source", "fld_solve", "fld_upsample"]:
            self.assertGreaterEqual(report["seconds"][stage], 0.0)
        s1 = values(single, "radiance")
        density = vdb.read(src, "density")
        voxel = density.transform.voxelSize()[0] ** 3
        dens = {tuple(i.min): i.value for i in density.citerOnValues() if i.value > 0}
        source = sum(20 * d * 0.99 * 4 * math.pi * sum(s1[k]) for k, d in dens.items())
        self.assertGreaterEqual(stats["source"], source * voxel * (1 - 1e-4))
        self.assertLessEqual(stats["source"], source * voxel * 1.02)
        mean_density = sum(dens.values()) / len(dens)
        extent = 48 * density.transform.voxelSize()[0]  # the cloud's index box spans 48 voxels
        for g, cells in ((0.85, 12), (0.0, 21)):
            sigma_tr = 20 * mean_density * (1 - 0.99 * g)
            if g == 0.0:
                _, q = self.bake(src, *[x if x != "0.85" else "0" for x in lights], "--method",
                                 "fld", out="fld0.vdb")
                stats0 = json.loads(q.stdout)["fld"]
            else:
                stats0 = stats
            self.assertAlmostEqual(stats0["mean_sigma_tr"], sigma_tr, delta=1e-6 * sigma_tr)
            self.assertEqual(stats0["resolution"], max(12, math.ceil(extent * sigma_tr)))
            self.assertEqual(stats0["resolution"], cells)
        self.assertGreater(self.assert_s1_plus_ms(single, fld, dens), 0.5 * len(dens))
        # ms_l1 from the flux by default (g 0.85): the light flows, so the moment is not 0.
        self.assertEqual(stats["l1"], "on")
        self.assertGreater(max(max(abs(x) for x in v) for v in values(fld, "ms_l1y").values()), 0.0)

    def test_keep_state_and_warm_start(self):
        """--keep-state writes the solved fluence as one grid fld_phi and says so in the
        metadata (vdbscatter_fld_state = phi); --warm-start from it starts the first solve and
        its limiter there: on the cloud sample (low, g 0.85) 33 CG iterations and 3 solves
        against the cold 57 and 5 were measured, asserted at most 2/3 of the cold count, with
        ms within 1% of the peak of the cold bake's (0.4% measured: the limiter's updates stop
        once phi changes by under 1%, so warm and cold stop at different points of them). The
        same cloud indexed from elsewhere (another grid origin, the same world place) starts as
        warm through world space (by index the file has no value there: a cold start); a cloud
        grown by 16 voxels along x (another FLD grid, cells the file never saw) converges to its
        own cold bake's ms as well, in fewer iterations (54 against 63 measured). A file without
        the state is refused (exit 2, one line naming --warm-start and how to bake one)."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        base = ["--density-scale", "20", "--albedo", "0.99", "--g", "0.85", "--sun",
                "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--quality", "low", "--json", "--method",
                "fld"]
        cold, p = self.bake(src, *base, "--keep-state", out="cold.vdb")
        cold_stats = json.loads(p.stdout)["fld"]
        self.assertFalse(cold_stats["warm_start"])
        meta = vdb.readAllGridMetadata(cold)
        self.assertIn("fld_phi", {g["name"] for g in meta})
        self.assertEqual(meta[0]["vdbscatter_fld_state"], "phi")
        # phi is the fluence, 4 pi ms before the upsampling's filter: positive where ms is.
        phi, ms_cold = values(cold, "fld_phi"), values(cold, "ms")
        self.assertEqual(phi.keys(), ms_cold.keys())
        self.assertGreater(min(v[1] for k, v in phi.items() if ms_cold[k][1] > 0), 0.0)

        def converges(src, start, reference, most=None, out="warm.vdb"):
            lit, q = self.bake(src, *base, "--warm-start", start, out=out)
            stats = json.loads(q.stdout)["fld"]
            self.assertTrue(stats["warm_start"], out)
            self.assertLessEqual(stats["residual"], 1e-4)
            if most is not None:
                self.assertLessEqual(stats["cg_iterations"], most, out)
            want, got = values(reference, "ms"), values(lit, "ms")
            self.assertEqual(want.keys(), got.keys())
            peak = max(max(v) for v in want.values())
            worst = max(abs(a - b) for k in want for a, b in zip(want[k], got[k]))
            self.assertLessEqual(worst, 1e-2 * peak, out)
            self.assertNotIn("fld_phi", {g["name"] for g in vdb.readAllGridMetadata(lit)})
            return stats

        warm = converges(src, cold, cold, most=2 * cold_stats["cg_iterations"] // 3)
        self.assertLess(warm["updates"], cold_stats["updates"])

        # The same cloud with its grid origin moved by (40, -30, 25) voxels, the transform
        # moved back: every voxel at the same world point under another index.
        density = vdb.read(src, "density")
        voxel = density.transform.voxelSize()[0]
        origin = density.transform.indexToWorld((0, 0, 0))

        def volume(name, offsets, shift=(0, 0, 0)):
            grid = vdb.FloatGrid()
            grid.name = "density"
            grid.gridClass = vdb.GridClass.FOG_VOLUME
            grid.transform = vdb.createLinearTransform(
                [[voxel, 0, 0, 0], [0, voxel, 0, 0], [0, 0, voxel, 0],
                 [*(origin[a] - shift[a] * voxel for a in range(3)), 1]])
            acc = grid.getAccessor()
            for item in density.citerOnValues():
                for d in offsets:
                    ijk = tuple(item.min[a] + shift[a] + d[a] for a in range(3))
                    acc.setValueOn(ijk, max(acc.getValue(ijk), item.value))
            path = self.path(name)
            vdb.write(path, grids=[grid])
            return path

        shifted = volume("shifted.vdb", [(0, 0, 0)], shift=(40, -30, 25))
        shifted_cold, _ = self.bake(shifted, *base, out="shifted_cold.vdb")
        converges(shifted, cold, shifted_cold, most=2 * cold_stats["cg_iterations"] // 3,
                  out="shifted_warm.vdb")
        grown = volume("grown.vdb", [(0, 0, 0), (16, 0, 0)])
        grown_cold, r = self.bake(grown, *base, out="grown_cold.vdb")
        converges(grown, cold, grown_cold, most=json.loads(r.stdout)["fld"]["cg_iterations"],
                  out="grown_warm.vdb")

        # A lit VDB without FLD's state: another method's, or no state at all.
        svd, _ = self.bake(src, *base[:-1], "svd", "--keep-state", out="svd.vdb")
        plain, _ = self.bake(src, *base, out="plain.vdb")
        for start in (svd, plain):
            line = self.assert_bad_input(["bake", src, "-o", self.path("out.vdb"), *base,
                                          "--warm-start", start], "--warm-start")
            self.assertIn("--method fld --keep-state", line)


class Collisions(Base):
    def test_first_collisions_of_a_sun_on_the_cube(self):
        """The light FLD and SVD start from, a sun at normal incidence on the homogeneous cube
        sample: every column of voxels stops 1 - exp(-tau) of the sun's irradiance, tau the
        column's optical depth, so the source is albedo E h^2 sum (1 - exp(-tau)) over the
        columns (and channels). At tau 50 (2.5 per voxel) to 1e-6: the point rule,
        sigma_s 4 pi S1 at the voxel centres, gave 0.78 of it (sinh(1.25) / 1.25 too little).
        At tau 0.5 (thin voxels, the point rule's own ground) to 1e-4."""
        src = os.path.join(SAMPLES, "cube.vdb")
        density = vdb.read(src, "density")
        h = density.transform.voxelSize()[0]
        columns = {}
        for i in density.citerOnValues():
            key = (i.min[0], i.min[2])
            columns[key] = columns.get(key, 0.0) + i.value
        thick = max(columns.values())
        for tau, tolerance in ((50.0, 1e-6), (0.5, 1e-4)):
            scale = tau / (thick * h)
            want = 3 * 0.9 * h * h * sum(1 - math.exp(-scale * h * c) for c in columns.values())
            args = ["--density-scale", str(scale), "--albedo", "0.9", "--g", "0", "--sun",
                    "0,-1,0", "--quality", "low", "--json"]
            for method, key in (("fld", "source"), ("svd", "first_power")):
                _, p = self.bake(src, *args, "--method", method, out=f"{method}.vdb")
                self.assertEqual(p.returncode, 0, p.stderr)
                got = json.loads(p.stdout)[method][key]
                self.assertAlmostEqual(got, want, delta=tolerance * want, msg=f"{method} tau {tau}")


class Svd(Base):
    LIGHTS = ["--density-scale", "20", "--albedo", "0.99", "--sun", "0.3,-1,0.2", "--env",
              "0.2,0.3,0.5", "--quality", "low", "--json"]

    def test_svd_adds_ms_and_balances_energy(self):
        """bake --method svd on the cloud sample at --quality low: radiance is the single bake's
        S1 plus ms to float rounding, ms >= 0 and positive inside the cloud; the report gives the
        quality's D = 32 and 16 cells across, every sweep's power balance within 1e-4, and a
        converged residual within the quality's 3e-2. With g 0 (no delta-M) the first sweep
        emits at least sigma_s 4 pi S1 summed over the voxels times their volume (the point
        rule, which undercounts the optically thick voxels here) and within 2% of it
        (Collisions has the exact value); with g 0.85 delta-M moves f into the beam and the
        report says so."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        density = vdb.read(src, "density")
        voxel = density.transform.voxelSize()[0] ** 3
        dens = {tuple(i.min): i.value for i in density.citerOnValues() if i.value > 0}
        # S1 is the fluence over 4 pi, the same for every g: one single bake serves both.
        single, _ = self.bake(src, *self.LIGHTS, out="single.vdb")
        for g in ("0", "0.85"):
            lights = self.LIGHTS + ["--g", g]
            lit, p = self.bake(src, *lights, "--method", "svd", out=f"svd{g}.vdb")
            self.assertEqual(p.returncode, 0, p.stderr)
            report = json.loads(p.stdout)
            stats = report["svd"]
            self.assertEqual(stats["directions"], 32)
            self.assertEqual(stats["resolution"], 16)
            self.assertTrue(stats["converged"])
            self.assertLessEqual(stats["residual"], 3e-2)
            self.assertLessEqual(stats["balance"], 1e-4)
            for stage in ["svd_source", "svd_solve", "svd_upsample"]:
                self.assertGreaterEqual(report["seconds"][stage], 0.0)
            self.assertGreater(self.assert_s1_plus_ms(single, lit, dens), 0.5 * len(dens))
            if g == "0":
                self.assertEqual(stats["delta_m_f"], 0.0)
                self.assertEqual(stats["terms"], 1)  # g 0 is rank 1
                s1 = values(single, "radiance")
                scattered = voxel * sum(20 * d * 0.99 * 4 * math.pi * sum(s1[k])
                                        for k, d in dens.items())
                self.assertGreaterEqual(stats["first_power"], scattered * (1 - 1e-4))
                self.assertLessEqual(stats["first_power"], scattered * 1.02)
            else:
                self.assertGreater(stats["delta_m_f"], 0.1)
                self.assertLess(stats["g_scaled"], 0.85)

    def test_keep_state_and_warm_start(self):
        """--keep-state writes N moment grids svd_m0000... and the D and N they belong to;
        --warm-start from them converges in far fewer iterations to the same ms (within 1% of
        the peak), takes D and N from the file, and refuses other D, other g or a file
        without state (exit 2, no output)."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        base = self.LIGHTS + ["--g", "0.6", "--method", "svd", "--residual", "1e-3"]
        cold, p = self.bake(src, *base, "--svd-terms", "12", "--keep-state", out="cold.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        cold_stats = json.loads(p.stdout)["svd"]
        self.assertEqual(cold_stats["terms"], 12)
        names = {g["name"] for g in vdb.readAllGridMetadata(cold)}
        self.assertEqual({n for n in names if n.startswith("svd_m")},
                         {f"svd_m{k:04d}" for k in range(12)})
        meta = vdb.readAllGridMetadata(cold)[0]  # every grid carries the file's metadata
        self.assertEqual(meta["vdbscatter_svd_directions"], "32")
        self.assertEqual(meta["vdbscatter_svd_terms"], "12")
        warm, q = self.bake(src, *base, "--warm-start", cold, out="warm.vdb")
        self.assertEqual(q.returncode, 0, q.stderr)
        warm_stats = json.loads(q.stdout)["svd"]
        self.assertEqual((warm_stats["directions"], warm_stats["terms"]), (32, 12))
        self.assertEqual((cold_stats["warm_start"], warm_stats["warm_start"]), (False, True))
        self.assertLessEqual(warm_stats["iterations"], cold_stats["iterations"] // 2)
        ms_cold, ms_warm = values(cold, "ms"), values(warm, "ms")
        peak = max(max(v) for v in ms_cold.values())
        worst = max(abs(a - b) for k in ms_cold for a, b in zip(ms_cold[k], ms_warm[k]))
        self.assertLessEqual(worst, 1e-2 * peak)
        self.assertNotIn("svd_m0000", {g["name"] for g in vdb.readAllGridMetadata(warm)})
        for extra, needle in ((["--svd-directions", "48"], "--warm-start"),
                              (["--g", "0.5"], "--warm-start")):
            self.assert_bad_input(["bake", src, "-o", self.path("out.vdb"), *base, "--warm-start",
                                   cold, *extra], needle)


class InetState(Base):
    def test_keep_state_and_warm_start(self):
        """--method inet --keep-state writes one vec3 grid per direction, inet_r0000...
        (the RGB radiance reaching the voxel's particles along it), and the D they belong to;
        --warm-start from it (the same particles: each starts from its voxel's mean) reports
        warm_start and stops by the same rule in at most half the sweeps (measured 15 against
        43 on the cloud sample at low), its ms within 1% of the cold bake's peak (measured
        0.09%); a state starts another seed's particles too. Another --inet-directions, an svd
        state and a file without state are refused (exit 2, one line, no output)."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        base = ["--scene", os.path.join(SAMPLES, "cloud.json"), "--method", "inet",
                "--quality", "low", "--json"]
        cold, p = self.bake(src, *base, "--keep-state", out="cold.vdb")
        self.assertEqual(p.returncode, 0, p.stderr)
        cold_stats = json.loads(p.stdout)["inet"]
        self.assertEqual(cold_stats["directions"], 64)
        names = {g["name"] for g in vdb.readAllGridMetadata(cold)}
        self.assertEqual({n for n in names if n.startswith("inet_r")},
                         {f"inet_r{d:04d}" for d in range(64)})
        meta = vdb.readAllGridMetadata(cold)[0]
        self.assertEqual(meta["vdbscatter_inet_directions"], "64")
        state = values(cold, "inet_r0007")
        self.assertTrue(all(c >= 0.0 for v in state.values() for c in v))
        self.assertGreater(sum(1 for v in state.values() if v[1] > 0.0), 100)
        warm, q = self.bake(src, *base, "--warm-start", cold, out="warm.vdb")
        self.assertEqual(q.returncode, 0, q.stderr)
        warm_stats = json.loads(q.stdout)["inet"]
        self.assertEqual((cold_stats["warm_start"], warm_stats["warm_start"]), (False, True))
        self.assertTrue(warm_stats["converged"])
        self.assertLessEqual(warm_stats["residual"], 1e-2)
        self.assertLessEqual(warm_stats["iterations"], cold_stats["iterations"] // 2)
        ms_cold, ms_warm = values(cold, "ms"), values(warm, "ms")
        peak = max(max(v) for v in ms_cold.values())
        worst = max(abs(a - b) for k in ms_cold for a, b in zip(ms_cold[k], ms_warm[k]))
        self.assertLessEqual(worst, 1e-2 * peak)
        self.assertNotIn("inet_r0000", {g["name"] for g in vdb.readAllGridMetadata(warm)})
        _, r = self.bake(src, *base, "--warm-start", cold, "--inet-seed", "5", out="seed.vdb")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertTrue(json.loads(r.stdout)["inet"]["warm_start"])
        svd, s = self.bake(src, "--scene", os.path.join(SAMPLES, "cloud.json"), "--method", "svd",
                           "--quality", "low", "--svd-directions", "8", "--svd-res", "8",
                           "--keep-state", "-q", out="svd.vdb")
        self.assertEqual(s.returncode, 0, s.stderr)
        out = self.path("out.vdb")
        line = self.assert_bad_input(["bake", src, "-o", out, *base, "--warm-start", cold,
                                      "--inet-directions", "32"], "--warm-start")
        self.assertIn("64 directions, not 32", line)
        for state_file in (svd, src):
            line = self.assert_bad_input(["bake", src, "-o", out, *base, "--warm-start",
                                          state_file], "--warm-start")
            self.assertIn("--method inet --keep-state", line)


class PhaseSvd(Base):
    def test_rows_for_every_term(self):
        """phase-svd --json: one row per N from 1 to D, the error falling to 0 at N = D; g 0
        is rank 1 (exact with one term)."""
        rep = json.loads(run("phase-svd", "--g", "0.7", "--directions", "32", "--json").stdout)
        self.assertEqual(rep["g"], 0.7)
        self.assertEqual(rep["directions"], 32)
        rows = rep["rows"]
        self.assertEqual([r["terms"] for r in rows], list(range(1, 33)))
        for a, b in zip(rows, rows[1:]):
            self.assertLessEqual(b["rmse"], a["rmse"])
        self.assertEqual(rows[-1]["rmse"], 0.0)
        flat = json.loads(run("phase-svd", "--g", "0", "--directions", "16", "--json").stdout)
        self.assertLess(flat["rows"][0]["rmse"], 1e-12)


class Pop(Base):
    def test_pop_adds_ms_to_the_exact_s1(self):
        """bake --method pop on the cloud sample (a sun and a constant sky): radiance is the
        single-scatter bake's S1 plus ms to float rounding, ms is positive inside the cloud, and
        the report gives the grids, the two stages' iterations and a residual at most
        epsilon_L (1e-2 at --quality low: the isotropic stage ran to its tolerance, not its
        cap)."""
        src = os.path.join(SAMPLES, "cloud.vdb")
        lights = ["--density-scale", "20", "--albedo", "0.99", "--g", "0.85", "--sun",
                  "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--quality", "low", "--json"]
        single, p = self.bake(src, *lights, out="single.vdb")
        pop, p = self.bake(src, *lights, "--method", "pop", "--pop-res", "8", out="pop.vdb")
        report = json.loads(p.stdout)
        self.assertEqual(report["method"], "pop")
        stats = report["pop"]
        self.assertEqual(stats["grids"], 1 + 8)  # the sun and the low quality's 8 ordinates
        self.assertEqual(stats["resolution"], 8)
        self.assertGreater(stats["iterations_anisotropic"], 0)
        self.assertGreater(stats["iterations_isotropic"], 0)
        self.assertLessEqual(stats["residual"], 1e-2)
        self.assertGreater(stats["seeded"], 0.0)
        # The merge conserves: fluence x volume before and after the splat.
        self.assertAlmostEqual(stats["merge_out"], stats["merge_in"], delta=1e-9 * stats["merge_in"])
        for stage in ["pop_sweep", "pop_seed", "pop_propagate", "pop_isotropic", "pop_merge", "pop_upsample"]:
            self.assertGreaterEqual(report["seconds"][stage], 0.0)
        self.assertGreater(self.assert_s1_plus_ms(single, pop),
                           0.5 * len(values(pop, "radiance")))
        meta = vdb.readAllGridMetadata(pop)[0]
        self.assertEqual(meta["vdbscatter_method"], "pop")


    def test_pop_point_lights(self):
        """POP part 2: a point light inside the smoke sample and one outside the cloud sample
        (above it) bake with radial grids: the outputs are finite and non-negative, ms is
        positive somewhere, the radial grid's seed is its S1 beam's loss (1e-5) and the merge
        conserves fluence x volume."""
        for sample, scale, point in [("smoke", "10", "0,-0.5,0"), ("cloud", "20", "0,1.6,0")]:
            with self.subTest(sample=sample):
                src = os.path.join(SAMPLES, sample + ".vdb")
                out, p = self.bake(src, "--method", "pop", "--point", point + ":2,2,2",
                                   "--density-scale", scale, "--albedo", "0.99", "--g", "0.3",
                                   "--quality", "low", "--json", out=sample + "_point.vdb")
                pop = json.loads(p.stdout)["pop"]
                self.assertEqual(pop["radial_grids"], 1)
                self.assertEqual(pop["grids"], 0)
                self.assertEqual(pop["radial"], 8)
                self.assertAlmostEqual(pop["seeded"], pop["beam_loss"], delta=1e-5 * pop["beam_loss"])
                self.assertAlmostEqual(pop["merge_out"], pop["merge_in"], delta=1e-9 * pop["merge_in"])
                positive = 0
                for name in ["radiance", "ms", "ms_l1x", "ms_l1y", "ms_l1z"]:
                    grid = values(out, name)
                    for v in grid.values():
                        for c in v:
                            self.assertTrue(math.isfinite(c), name)
                            if name in ("radiance", "ms"):
                                self.assertGreaterEqual(c, 0.0, name)
                    if name == "ms":
                        positive = sum(1 for v in grid.values() if v[0] > 0.0)
                self.assertGreater(positive, 0)

    def test_pop_importance_is_opt_in_and_reported(self):
        """--pop-importance on the cloud under the bundled sky map (scene file with a camera):
        the report says "on" with the frustum grid's 16^3 cells, the sky ordinates (and so ms)
        change; without the flag the report says "off"."""
        scene = os.path.join(SAMPLES, "cloud_sky.json")
        src = os.path.join(SAMPLES, "cloud.vdb")
        plain, p = self.bake(src, "--scene", scene, "--method", "pop", "--pop-ordinates", "4",
                             "--quality", "low", "--json", out="plain.vdb")
        self.assertEqual(json.loads(p.stdout)["pop"]["importance"], "off")
        imp, p = self.bake(src, "--scene", scene, "--method", "pop", "--pop-ordinates", "4",
                           "--quality", "low", "--pop-importance", "--json", out="imp.vdb")
        stats = json.loads(p.stdout)["pop"]
        self.assertEqual(stats["importance"], "on")
        self.assertEqual(stats["importance_cells"], 16 ** 3)
        self.assertGreater(stats["importance_iterations"], 0)
        a, b = values(plain, "ms"), values(imp, "ms")
        self.assertGreater(max(abs(a[k][0] - b[k][0]) for k in a), 0.0)

    def test_pop_seed_is_the_beams_loss(self):
        """POP seeds what the S1 beam loses, times the albedo. On the cube sample under a sun
        straight down: per sub-column the seeds telescope to albedo E (1 - T) of the whole
        column (the report's seeded against beam_loss, to 1e-5: every grid holds the medium and
        no cell's share is lost), and seeded / cell side = albedo E integral (1 - T) dA, with T
        computed here from the voxel values alone (the trilinear interpolant integrates along y
        to the column sums of the voxels; 16 x 16 samples per voxel across), within 1%: the
        seeding's sub-columns are half a voxel apart (measured 0.26%; one per voxel gave 2.1%
        on these sharp edges)."""
        src = os.path.join(SAMPLES, "cube.vdb")
        _, p = self.bake(src, "--method", "pop", "--sun", "0,-1,0:2,2,2", "--density-scale", "3",
                         "--albedo", "0.8", "--json", out="cube.vdb")
        pop = json.loads(p.stdout)["pop"]
        self.assertAlmostEqual(pop["seeded"], pop["beam_loss"], delta=1e-5 * pop["beam_loss"])
        grid = vdb.read(src, "density")
        dx = grid.transform.voxelSize()[0]
        cols = {}
        for item in grid.citerOnValues():
            self.assertEqual(item.min, item.max)  # voxels, no tiles
            key = (item.min[0], item.min[2])
            cols[key] = cols.get(key, 0.0) + item.value
        xs = [k[0] for k in cols]
        zs = [k[1] for k in cols]
        q, total = 16, 0.0
        for a in range((max(xs) - min(xs) + 3) * q):
            u = min(xs) - 1.5 + (a + 0.5) / q
            i, fu = math.floor(u), u - math.floor(u)
            for b in range((max(zs) - min(zs) + 3) * q):
                v = min(zs) - 1.5 + (b + 0.5) / q
                k, fv = math.floor(v), v - math.floor(v)
                col = ((1 - fu) * (1 - fv) * cols.get((i, k), 0.0) +
                       fu * (1 - fv) * cols.get((i + 1, k), 0.0) +
                       (1 - fu) * fv * cols.get((i, k + 1), 0.0) + fu * fv * cols.get((i + 1, k + 1), 0.0))
                total += 1.0 - math.exp(-3.0 * dx * col)
        expected = 0.8 * 2.0 * 3 * total * (dx / q) ** 2  # albedo E, three channels
        self.assertAlmostEqual(pop["seeded"] / pop["cell_side"], expected, delta=0.01 * expected)


class Samples(Base):
    def test_every_sample(self):
        for name in ["cloud", "smoke", "sphere", "slab", "cube"]:
            out = self.path(name + ".vdb")
            run("sample", name, "-o", out, "--res", "24", check=0)
            self.assertEqual(subprocess.run(["vdb_print", out], capture_output=True).returncode, 0)
            info = json.loads(run("info", out, "--json", check=0).stdout)
            g = info["grids"][0]
            self.assertEqual(g["name"], "density")
            self.assertAlmostEqual(g["voxel_size"][0], 2 / 24, places=12)

    def test_input_overrides_the_scene_volume(self):
        # IN.vdb on the command line is what is baked, and what the report's and the lit VDB's
        # scene name: a re-bake from the recorded scene must read the same volume.
        out = self.path("lit.vdb")
        p = run("bake", sample("sphere.vdb"), "--scene", sample("cloud.json"), "--method", "single",
                "--quality", "low", "--backend", "cpu", "--json", "-q", "-o", out, check=0)
        report = json.loads(p.stdout)
        self.assertEqual(report["input"], sample("sphere.vdb"))
        self.assertEqual(report["scene"]["volume"]["file"], sample("sphere.vdb"))
        meta = vdb.readAllGridMetadata(out)[0]
        self.assertEqual(json.loads(meta["vdbscatter_scene"])["volume"]["file"], sample("sphere.vdb"))
        self.assertEqual(vdb.read(out, "density").activeVoxelCount(),
                         vdb.read(sample("sphere.vdb"), "density").activeVoxelCount())

    def test_sphere_round_trip(self):
        res = 20
        out = self.path("sphere.vdb")
        run("sample", "sphere", "-o", out, "--res", res, check=0)
        g = vdb.read(out, "density")
        h = 2.0 / res
        expected = set()
        for i in range(res):
            for j in range(res):
                for k in range(res):
                    x, y, z = (-1 + (c + 0.5) * h for c in (i, j, k))
                    if x * x + y * y + z * z <= 0.8 * 0.8:
                        expected.add((i, j, k))
        got = {v.min for v in g.citerOnValues()}
        self.assertEqual(got, expected)
        self.assertTrue(all(v.value == 1.0 for v in g.citerOnValues()))
        for ijk in [(0, 0, 0), (3, 5, 7)]:
            w = g.transform.indexToWorld(ijk)
            for c, x in zip(ijk, w):
                self.assertAlmostEqual(x, -1 + (c + 0.5) * h, places=12)

    def test_info_thickness(self):
        out = self.path("slab.vdb")
        run("sample", "slab", "-o", out, "--res", "32", check=0)
        info = json.loads(run("info", out, "--json", "--density-scale", "4", check=0).stdout)
        t = info["optical_thickness"]
        # 8 rows of voxels |y| <= 0.25 -> interpolant support spans 8 voxels in y: tau = 4 * 8 h
        self.assertAlmostEqual(t["axis_max"][1], 4 * 8 * (2 / 32), delta=1e-4)
        self.assertAlmostEqual(t["voxel_max"], 4 * (2 / 32), delta=1e-9)

    def test_info_gpu(self):
        p = run("info", "--gpu", "--json", check=0)
        gpu = json.loads(p.stdout)["gpu"]
        self.assertTrue(gpu["available"])
        self.assertRegex(gpu["version"], r"^4\.[3-6]")


class Occluders(Base):
    """Scenes with occluders and fog: bake and render check every OBJ file (one error line,
    exit 2, no output) and otherwise warn once that they ignore them."""

    def scene(self, name, occluders, fog=None):
        with open(os.path.join(SAMPLES, "cloud.json")) as f:
            scene = json.load(f)
        scene["volume"]["file"] = os.path.join(SAMPLES, "cloud.vdb")
        scene["solver"] = {"quality": "low"}
        scene["occluders"] = occluders
        if fog is not None:
            scene["fog"] = fog
        path = self.path(name)
        with open(path, "w") as f:
            json.dump(scene, f)
        return path

    def test_bad_occluders_are_one_error_line(self):
        with open(self.path("bad.obj"), "w") as f:
            f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
        cases = [
            (self.scene("malformed.json", [{"type": "obj", "file": "bad.obj"}]),
             "occluders[0].file: " + self.path("bad.obj") + ":4: f: corner '9': vertex index 9 out of range"),
            (self.scene("missing.json", [{"type": "box", "min": [0, 1, 0], "max": [1, 2, 1]},
                                         {"type": "obj", "file": "missing.obj"}]),
             "occluders[1].file: " + self.path("missing.obj") + ": cannot open"),
            (self.scene("key.json", [{"type": "sphere", "center": [0, 1, 0], "radius": 0.2, "colour": 1}]),
             'occluders[0]: unknown key "colour"'),
            (self.scene("range.json", [{"type": "sphere", "center": [0, 1, 0], "radius": 0}]),
             "occluders[0].radius: must be finite and > 0"),
            (self.scene("fog.json", [], fog={"sigma_t": -1}), "fog.sigma_t"),
        ]
        for scene, needle in cases:
            line = self.assert_bad_input(["bake", "--scene", scene, "-o", self.path("out.vdb")], needle)
            self.assertTrue(line.startswith("vdbscatter bake: scene " + scene + ": "), line)
            self.assert_bad_input(["render", "--scene", scene, "-o", self.path("out.png")], needle,
                                  output="out.png")

    def test_bake_and_render_warn_once(self):
        scene = self.scene("box.json", [{"type": "box", "min": [-0.4, 0.9, -0.4], "max": [0.2, 1.1, 0.2]}])
        out = self.path("lit.vdb")
        p = run("bake", "--scene", scene, "-o", out, "--json", check=0)
        self.assertTrue(os.path.exists(out))
        warnings = [l for l in p.stderr.splitlines() if "warning" in l]
        self.assertEqual(warnings, ["vdbscatter: warning: bake: ignoring 1 occluder of the scene "
                                    "(only vdbscatter-view draws it)"], p.stderr)
        # the report's scene keeps them as given
        report = json.loads(p.stdout)
        self.assertEqual(report["scene"]["occluders"],
                         [{"type": "box", "min": [-0.4, 0.9, -0.4], "max": [0.2, 1.1, 0.2],
                           "albedo": [0.5, 0.5, 0.5]}])
        image = self.path("box.png")
        p = run("render", "--scene", scene, "-o", image, "--size", "32x24", check=0)
        self.assertTrue(os.path.exists(image))
        warnings = [l for l in p.stderr.splitlines() if "warning" in l]
        self.assertEqual(len(warnings), 1, p.stderr)
        self.assertIn("render: ignoring 1 occluder of the scene", warnings[0])
        # -q silences it
        p = run("render", "--scene", scene, "-o", image, "--size", "32x24", "-q", check=0)
        self.assertEqual(p.stderr, "")

    def test_sample_scene(self):
        """samples/cloud_occluder.json: the pillar OBJ, a sphere, a floor and the fog."""
        image = self.path("cloud_occluder.png")
        p = run("render", "--scene", os.path.join(SAMPLES, "cloud_occluder.json"), "-o", image,
                "--size", "32x24", "--quality", "low", check=0)
        self.assertTrue(os.path.exists(image))
        warnings = [l for l in p.stderr.splitlines() if "warning" in l]
        self.assertEqual(warnings, ["vdbscatter: warning: render: ignoring 3 occluders and the fog of "
                                    "the scene (only vdbscatter-view draws them)"], p.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
