#!/usr/bin/python3
"""The Blender hand-off (scripts/blender/load_lit_vdb.py, docs/handoff.md) against vdbscatter's
own renders: a lit VDB of the cloud sample (g 0.85, a sun and a constant sky) rendered by
Blender Cycles, headless, on the CPU.

- ms mode (Cycles' own single scattering from recreated lamps and world, plus the lit VDB's
  multiple scattering as emission) against the Monte-Carlo reference of the density: within
  the baked method's own error against the same reference, plus 0.05; and Cycles' single
  scattering alone (no emission) must be clearly worse, so the emission is what closes the gap.
- full mode (all light from the grids as emission, format 2 lit VDBs) against
  `vdbscatter render --mode baked` of the same file and camera: within 0.05 plus the seed
  noise (relative RMSE between two Cycles seeds / sqrt 2).

Relative RMSE = sqrt(sum (a - b)^2 / sum b^2) over pixels and RGB (`vdbscatter compare`'s
relrmse). Skipped when `blender` is not on PATH. Pictures are 96x72; a few minutes on 2 cores."""
import json
import math
import os
import shutil
import subprocess
import tempfile
import unittest

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
BLENDER = shutil.which("blender")
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts", "blender", "load_lit_vdb.py")

SIZE = "96x72"
CAMERA = "0,0.6,4.5:0,0,0:35"   # samples/cloud.json's camera
CYCLES_SPP = 64
FULL_SIZE = "64x48"
FULL_SPP = 16
REFERENCE_SPP = 1024


def run(*args, timeout=900):
    p = subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        raise AssertionError(f"{args}: exit {p.returncode}\nstdout: {p.stdout[-3000:]}\nstderr: {p.stderr[-3000:]}")
    return p


def relrmse(a, b):
    out = json.loads(run(EXE, "compare", a, b, "--json").stdout)
    value = out["relrmse"]
    if value is None or not math.isfinite(value):
        raise AssertionError(f"compare {a} {b}: relrmse {value}")
    return value


def grid_names(vdb):
    out = json.loads(run(EXE, "info", vdb, "--json").stdout)
    return {g["name"] for g in out["grids"]}


@unittest.skipIf(BLENDER is None, "blender is not on PATH (apt-get install blender, or scripts/setup.sh --blender)")
class BlenderHandoff(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="vdbscatter-blender-", dir=os.environ.get("VDBSCATTER_TMP"))
        cls.lit = cls.path("cloud_lit.vdb")
        run(EXE, "bake", os.path.join(SAMPLES, "cloud.vdb"), "--scene", os.path.join(SAMPLES, "cloud.json"),
            "-o", cls.lit, "--method", "svd", "--quality", "low", "-q")
        cls.baked = cls.path("baked.exr")
        run(EXE, "render", cls.lit, "-o", cls.baked, "--mode", "baked", "--camera", CAMERA, "--size", SIZE, "-q")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    @classmethod
    def path(cls, name):
        return os.path.join(cls.dir, name)

    def cycles(self, mode, out, seed=1, spp=CYCLES_SPP, lit=None, size=SIZE):
        run(BLENDER, "-b", "--factory-startup", "-noaudio", "-P", SCRIPT, "--", lit or self.lit, "--mode", mode,
            "--out", out, "--camera", CAMERA, "--size", size, "--spp", spp, "--seed", seed)
        self.assertTrue(os.path.exists(out), out)
        return out

    def test_metadata_parser(self):
        """The script's own VDB header parser reads what the bake wrote."""
        p = run("/usr/bin/python3", SCRIPT, "--print-meta", self.lit)
        meta = json.loads(p.stdout)
        self.assertEqual(float(meta["vdbscatter_density_scale"]), 20.0)
        self.assertEqual([float(v) for v in meta["vdbscatter_albedo"].split(",")], [0.99, 0.99, 0.99])
        self.assertAlmostEqual(float(meta["vdbscatter_g"]), 0.85, places=6)
        scene = json.loads(meta["vdbscatter_scene"])
        self.assertEqual([l["type"] for l in scene["lights"]], ["sun", "env"])

    def test_ms_mode_against_reference(self):
        reference = self.path("reference.exr")
        run(EXE, "render", os.path.join(SAMPLES, "cloud.vdb"), "--scene", os.path.join(SAMPLES, "cloud.json"),
            "-o", reference, "--mode", "reference", "--spp", REFERENCE_SPP, "--seed", 7,
            "--camera", CAMERA, "--size", SIZE, "-q")
        ms = self.cycles("ms", self.path("cycles_ms.exr"))
        single = self.cycles("single", self.path("cycles_single.exr"))
        baked_err = relrmse(self.baked, reference)
        ms_err = relrmse(ms, reference)
        single_err = relrmse(single, reference)
        print(f"\nms mode: Cycles ms vs reference {ms_err:.4f}, baked vs reference {baked_err:.4f}, "
              f"Cycles single scattering alone vs reference {single_err:.4f}")
        self.assertLessEqual(ms_err, baked_err + 0.05)
        # not vacuous: without the lit VDB's emission Cycles misses the multiple scattering
        self.assertGreater(single_err, ms_err + 0.1)

    def test_full_mode_refuses_format_1(self):
        """No silent picture without the depth grids: exit 2, one line naming the format."""
        lit = self.lit
        if any(n.startswith("light_depth_") for n in grid_names(lit)):
            lit = self.path("format1.vdb")
            run(EXE, "bake", os.path.join(SAMPLES, "cloud.vdb"), "--scene", os.path.join(SAMPLES, "cloud.json"),
                "-o", lit, "--method", "single", "--store", "none", "-q")
        out = self.path("refused.exr")
        p = subprocess.run([BLENDER, "-b", "--factory-startup", "-noaudio", "-P", SCRIPT, "--", lit, "--mode", "full",
                            "--out", out, "--size", "32x24", "--spp", "1"], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 2, p.stdout[-2000:] + p.stderr[-2000:])
        self.assertIn("format 2", p.stdout + p.stderr)
        self.assertFalse(os.path.exists(out))

    def test_full_mode_against_baked_render(self):
        """Full mode (emission rebuilt from the stored depths and ms, no lamps) against
        `render --mode baked` of the same lit VDB: a sun and a sky at g 0.85. Six sky directions
        and 16 spp keep Cycles' shader (one attribute lookup per stored light) within minutes on
        two cores; the bar's noise term is measured between two seeds."""
        lit = self.path("full_lit.vdb")
        run(EXE, "bake", os.path.join(SAMPLES, "cloud.vdb"), "--scene", os.path.join(SAMPLES, "cloud.json"),
            "-o", lit, "--method", "svd", "--quality", "low", "--sky-directions", "6", "-q")
        names = grid_names(lit)
        self.assertIn("light_depth_000", names)
        self.assertIn("sky_depth_0005", names)
        baked = self.path("full_baked.exr")
        run(EXE, "render", lit, "-o", baked, "--camera", CAMERA, "--size", FULL_SIZE, "-q")
        a = self.cycles("full", self.path("cycles_full_1.exr"), seed=1, spp=FULL_SPP, lit=lit, size=FULL_SIZE)
        b = self.cycles("full", self.path("cycles_full_2.exr"), seed=2, spp=FULL_SPP, lit=lit, size=FULL_SIZE)
        err = relrmse(a, baked)
        noise = relrmse(a, b) / math.sqrt(2.0)
        print(f"\nfull mode: Cycles vs vdbscatter baked {err:.4f}, seed noise {noise:.4f}")
        self.assertLess(noise, 0.05)
        self.assertLessEqual(err, 0.05 + noise)

    def test_full_mode_refuses_point_lights(self):
        """A point light's depth grid is radial (docs/lit-vdb.md), which Cycles' shader nodes
        cannot sample: full mode says so and names the ms mode, no picture."""
        lit = self.path("point.vdb")
        run(EXE, "bake", os.path.join(SAMPLES, "cloud.vdb"), "--scene", os.path.join(SAMPLES, "cloud.json"),
            "--point", "0.9,0.5,0.6:1,1,1", "-o", lit, "--method", "single", "-q")
        out = self.path("point.exr")
        p = subprocess.run([BLENDER, "-b", "--factory-startup", "-noaudio", "-P", SCRIPT, "--", lit, "--mode", "full",
                            "--out", out, "--size", "32x24", "--spp", "1"], capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 2, p.stdout[-2000:] + p.stderr[-2000:])
        self.assertIn("--mode ms", p.stdout + p.stderr)
        self.assertFalse(os.path.exists(out))


if __name__ == "__main__":
    unittest.main(verbosity=2)
