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


def add_format2_grids(src, dst):
    """Writes dst = src plus the format 2 grids light_depth_NNN (one per sun and point light of
    the baked scene; no env) and the metadata vdbscatter_format and vdbscatter_lights, with
    every optical depth marched here in numpy (trilinear density, quarter-voxel steps): an
    oracle independent of the bake, so the full mode is tested before the bake writes them."""
    import numpy as np
    import pyopenvdb as vdb
    grids, meta = vdb.readAll(src)
    by = {g.name: g for g in grids}
    dens = by["density"]
    scale = float(meta["vdbscatter_density_scale"])
    scene = json.loads(meta["vdbscatter_scene"])
    lo, hi = dens.evalActiveVoxelBoundingBox()
    lo, hi = np.array(lo) - 2, np.array(hi) + 2
    arr = np.zeros(tuple(hi - lo + 1), dtype=np.float32)
    dens.copyToArray(arr, ijk=tuple(int(v) for v in lo))
    t0 = np.array(dens.transform.indexToWorld((0, 0, 0)))
    vs = np.array(dens.transform.voxelSize())
    coords = np.array([it["min"] for it in by["ms"].citerOnValues() if it["count"] == 1], dtype=np.float64)
    centres = t0 + coords * vs
    shape = np.array(arr.shape)

    def sample(w):
        idx = (w - t0) / vs - lo
        i0 = np.floor(idx).astype(int)
        f = idx - i0
        out = np.zeros(len(w))
        for corner in np.ndindex(2, 2, 2):
            ii = i0 + np.array(corner)
            ok = np.all((ii >= 0) & (ii < shape), axis=1)
            wt = np.prod(np.where(np.array(corner) == 1, f, 1 - f), axis=1)
            out[ok] += wt[ok] * arr[ii[ok, 0], ii[ok, 1], ii[ok, 2]]
        return out

    step, far = 0.25 * vs.min(), np.linalg.norm((hi - lo) * vs)

    def depth(d, length):
        tau, t = np.zeros(len(centres)), 0.0
        while t < far:
            act = t < length
            if not act.any():
                break
            seg = np.minimum(step, length[act] - t)
            tau[act] += sample(centres[act] + d[act] * (t + 0.5 * seg)[:, None]) * seg
            t += step
        return tau * scale

    entries, extra = [], []
    for light in scene["lights"]:
        name = "light_depth_%03d" % len(entries)
        if light["type"] == "sun":
            d = np.array(light["direction"], float)
            d /= np.linalg.norm(d)
            tau = depth(np.tile(-d, (len(centres), 1)), np.full(len(centres), far))
            entries.append({"grid": name, "type": "sun", "travel": d.tolist(), "radiance": light["irradiance"]})
        elif light["type"] == "point":
            d = np.array(light["position"], float) - centres
            r = np.linalg.norm(d, axis=1)
            tau = depth(d / r[:, None], r)
            entries.append({"grid": name, "type": "point", "position": light["position"],
                            "intensity": light["intensity"], "min_distance": 0.5 * float(vs.min())})
        else:
            raise AssertionError(f"add_format2_grids: {light['type']} lights are not marched here")
        g = vdb.FloatGrid()
        g.name, g.transform = name, dens.transform
        acc = g.getAccessor()
        for c, v in zip(coords.astype(int), tau):
            acc.setValueOn(tuple(int(x) for x in c), float(v))
        extra.append(g)
    meta["vdbscatter_format"] = "2"
    meta["vdbscatter_lights"] = json.dumps(entries)
    vdb.write(dst, grids=grids + extra, metadata=meta)


def have_pyopenvdb():
    p = subprocess.run(["/usr/bin/python3", "-c", "import numpy, pyopenvdb"], capture_output=True)
    return p.returncode == 0


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

    def cycles(self, mode, out, seed=1, spp=CYCLES_SPP, lit=None):
        run(BLENDER, "-b", "--factory-startup", "-noaudio", "-P", SCRIPT, "--", lit or self.lit, "--mode", mode,
            "--out", out, "--camera", CAMERA, "--size", SIZE, "--spp", spp, "--seed", seed)
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
        names = grid_names(self.lit)
        if not any(n.startswith("light_depth_") for n in names):
            self.skipTest("the bake wrote no light_depth_* grids (lit VDB format 2 not in this build)")
        a = self.cycles("full", self.path("cycles_full_1.exr"), seed=1)
        b = self.cycles("full", self.path("cycles_full_2.exr"), seed=2)
        err = relrmse(a, self.baked)
        noise = relrmse(a, b) / math.sqrt(2.0)
        print(f"\nfull mode: Cycles vs vdbscatter baked {err:.4f}, seed noise {noise:.4f}")
        self.assertLess(noise, 0.05)
        self.assertLessEqual(err, 0.05 + noise)

    def test_full_mode_on_marched_depths(self):
        """Full mode on a lit VDB given format 2 grids marched here (a sun and a point light,
        g 0.85) against `vdbscatter render --mode baked` (S1 by its exact march) of it."""
        if not have_pyopenvdb():
            self.skipTest("needs numpy and pyopenvdb in /usr/bin/python3 (python3-openvdb)")
        scene = self.path("sunpoint.json")
        with open(scene, "w") as f:
            json.dump({"volume": {"file": os.path.join(SAMPLES, "cloud.vdb"), "grid": "density",
                                  "density_scale": 20.0, "albedo": [0.99, 0.99, 0.99], "g": 0.85},
                       "lights": [{"type": "sun", "direction": [0.3, -1.0, 0.2], "irradiance": [3.0, 2.9, 2.7]},
                                  {"type": "point", "position": [0.9, 0.5, 0.6], "intensity": [0.6, 0.5, 0.4]}]}, f)
        lit1, lit2 = self.path("sunpoint.vdb"), self.path("sunpoint_f2.vdb")
        run(EXE, "bake", os.path.join(SAMPLES, "cloud.vdb"), "--scene", scene, "-o", lit1,
            "--method", "svd", "--quality", "low", "-q")
        run("/usr/bin/python3", "-c", "import sys; sys.path.insert(0, sys.argv[1]); import test_blender as t; "
            "t.add_format2_grids(sys.argv[2], sys.argv[3])", os.path.dirname(os.path.abspath(__file__)), lit1, lit2)
        baked = self.path("sunpoint_baked.exr")
        run(EXE, "render", lit2, "-o", baked, "--mode", "baked", "--s1", "march", "--camera", CAMERA,
            "--size", SIZE, "-q")
        a = self.cycles("full", self.path("sunpoint_full_1.exr"), seed=1, lit=lit2)
        b = self.cycles("full", self.path("sunpoint_full_2.exr"), seed=2, lit=lit2)
        err = relrmse(a, baked)
        noise = relrmse(a, b) / math.sqrt(2.0)
        print(f"\nfull mode, marched depths: Cycles vs vdbscatter baked {err:.4f}, seed noise {noise:.4f}")
        self.assertLess(noise, 0.05)
        self.assertLessEqual(err, 0.05 + noise)


if __name__ == "__main__":
    unittest.main(verbosity=2)
