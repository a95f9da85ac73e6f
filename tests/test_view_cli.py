#!/usr/bin/python3
"""`vdbscatter-view` through its screenshots, under xvfb-run with Mesa: the picture of a lit
cloud equals `vdbscatter render --mode baked` of the same camera, size and lights (2%
relative RMSE without interleaved sampling, 5% with it), the compute shader in the window's
context matches the C path, a density VDB opens with single scattering only, and bad files
and flags get one line, exit 2 and no image."""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_render_cli import read_png  # noqa: E402  (the small PNG reader of the render tests)

EXE = os.environ["VDBSCATTER"]
VIEW = os.environ["VDBSCATTER_VIEW"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
XVFB = ["xvfb-run", "-a", "-s", "-screen 0 1280x720x24"]


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def view(*args, check=None, display=True):
    cmd = (XVFB if display else []) + [VIEW, *map(str, args)]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def sample(name):
    return os.path.join(SAMPLES, name)


def relrmse(a, b):
    p = run("compare", a, b, "--json", check=0)
    return json.loads(p.stdout)["relrmse"]


class Base(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="vdbs_view_", dir=os.environ.get("VDBSCATTER_TMP"))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    @classmethod
    def path(cls, name):
        return os.path.join(cls.tmp, name)


class Screenshot(Base):
    """The lit cloud (POP bake, quality low) at the sample camera's 320x240."""

    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.lit = cls.path("cloud_lit.vdb")
        run("bake", "--scene", sample("cloud.json"), "--method", "pop", "--quality", "low", "-o", cls.lit,
            "-q", check=0)
        cls.rendered = cls.path("render.exr")
        run("render", cls.lit, "--mode", "baked", "-o", cls.rendered, "-q", check=0)

    def screenshot(self, name, *extra):
        out = self.path(name)
        view(self.lit, "--screenshot", out, "--backend", "cpu", "-q", *extra, check=0)
        return out

    def test_equals_render_without_interleave(self):
        shot = self.screenshot("plain.exr", "--no-interleave")
        error = relrmse(shot, self.rendered)
        print(f"\nviewer without interleaving against render --mode baked: relative RMSE {error:.2e}")
        self.assertLessEqual(error, 0.02)

    def test_equals_render_with_interleave(self):
        shot = self.screenshot("interleaved.exr")  # the default, 2 x 2
        error = relrmse(shot, self.rendered)
        print(f"\nviewer with 2x2 interleaving against render --mode baked: relative RMSE {error:.2e}")
        self.assertLessEqual(error, 0.05)
        # The gather is not a no-op: the phases really are dealt out.
        self.assertGreater(relrmse(shot, self.screenshot("plain2.exr", "--no-interleave")), 1e-4)

    def test_same_camera_and_png(self):
        out = self.path("moved.png")
        view(self.lit, "--screenshot", out, "--backend", "cpu", "--camera", "0,0.3,3:0,0,0:40", "--size",
             "48x36", "--exposure", "1", "--no-interleave", "-q", check=0)
        ref = self.path("moved_render.png")
        run("render", self.lit, "-o", ref, "--camera", "0,0.3,3:0,0,0:40", "--size", "48x36", "--exposure",
            "1", "-q", check=0)
        with open(out, "rb") as a, open(ref, "rb") as b:
            self.assertEqual(a.read()[:24], b.read()[:24])  # PNG signature and IHDR: same size
        self.assertLessEqual(relrmse(out, ref), 0.02)

    def test_shader_in_window_context_matches_c_path(self):
        small = ("--size", "48x36", "--quality", "low")
        gpu = self.path("gpu.exr")
        p = view(self.lit, "--screenshot", gpu, "--backend", "gpu", *small, check=0)
        self.assertNotIn("C (OpenMP", p.stderr)  # the summary names the GL renderer
        cpu = self.screenshot("cpu.exr", *small)
        error = relrmse(gpu, cpu)
        print(f"\nviewer compute shader (window context) against the C path: relative RMSE {error:.2e}")
        self.assertLessEqual(error, 1e-4)

    def test_rebake_for_a_moved_sun(self):
        """--rebake (the key b at start): the multiple scattering re-baked in the background for
        a new sun gives the picture of a lit VDB baked for that sun; without it the picture
        keeps the old sun's multiple scattering."""
        sun = ["--sun", "-0.6,-1,0.3:3,2.9,2.7", "--env", "0.2,0.3,0.5"]
        fresh = self.path("fresh_lit.vdb")
        run("bake", "--scene", sample("cloud.json"), "--method", "pop", "--quality", "low", *sun, "-o", fresh,
            "-q", check=0)
        ref = self.path("fresh.exr")
        run("render", fresh, "-o", ref, "--size", "64x48", "-q", check=0)
        shots = {}
        for name, extra in (("rebaked", ["--rebake"]), ("stale", [])):
            shots[name] = self.path(name + ".exr")
            view(self.lit, *sun, *extra, "--screenshot", shots[name], "--size", "64x48", "--backend", "cpu",
                 "--no-interleave", "-q", check=0)
        rebaked, stale = relrmse(shots["rebaked"], ref), relrmse(shots["stale"], ref)
        print(f"\nre-bake for a moved sun: relative RMSE {rebaked:.2e} against a bake for it, {stale:.2e} "
              f"without the re-bake")
        self.assertLessEqual(rebaked, 1e-4)
        self.assertGreater(stale, 100 * max(rebaked, 1e-6))

    def test_density_vdb_shows_single_scattering(self):
        out, ref = self.path("density.exr"), self.path("density_render.exr")
        p = view(sample("cloud.vdb"), "--scene", sample("cloud.json"), "--screenshot", out, "--backend", "cpu",
                 "--size", "48x36", "--no-interleave", check=0)
        self.assertIn("single scattering only", p.stderr)
        run("render", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--mode", "single", "-o", ref,
            "--size", "48x36", "-q", check=0)
        self.assertLessEqual(relrmse(out, ref), 1e-6)


def write_scene(path, **extra):
    """A scene over the cloud sample with a vertical sun and no sky, plus `extra` keys."""
    scene = {"volume": {"file": sample("cloud.vdb"), "density_scale": 0.0},
             "lights": [{"type": "sun", "direction": [0, -1, 0], "irradiance": 4.0}]}
    scene.update(extra)
    with open(path, "w") as f:
        json.dump(scene, f)
    return path


class Occluders(Base):
    def test_box_shadow_column_in_fog(self):
        """A box under a vertical sun in fog, seen from below inside its shadow column: the
        rays that stay in the shadow up to the box see no single scattering at all (black:
        no sky, the box's underside unlit), the rays that leave the column do."""
        scene = write_scene(self.path("column.json"),
                            occluders=[{"type": "box", "min": [-0.5, 1.5, -0.5], "max": [0.5, 1.8, 0.5]}],
                            fog={"sigma_t": 0.6, "g": 0.3, "box": {"min": [-3, -2, -3], "max": [3, 2, 3]}})
        out = self.path("column.png")
        size, fov = 81, 60.0
        view(sample("cloud.vdb"), "--scene", scene, "--screenshot", out, "--backend", "cpu", "--camera",
             "0,-1.5,0:0,1,0:%g" % fov, "--size", "%dx%d" % (size, size), "--no-interleave", "--exposure", "4",
             "-q", check=0)
        width, height, rgb = read_png(out)
        self.assertEqual((width, height), (size, size))
        tan_half = math.tan(math.radians(fov / 2))
        inside, outside, dark_outside = 0, 0, 0
        for py in range(size):
            for px in range(size):
                # The ray's slope off the vertical; it reaches y = 1.5 (the box) 3 units up.
                sx = (2 * (px + 0.5) / size - 1) * tan_half
                sy = (1 - 2 * (py + 0.5) / size) * tan_half
                reach = 3.0 * max(abs(sx), abs(sy))  # the camera's right and up are world axes
                value = max(rgb[3 * (py * size + px):3 * (py * size + px) + 3])
                if reach < 0.45:  # stays inside the column (half width 0.5) all the way
                    inside += 1
                    self.assertEqual(value, 0, (px, py))
                elif reach > 0.8:  # leaves it early: lit fog on most of its length
                    outside += 1
                    dark_outside += value == 0
        print(f"\nshadow column: {inside} rays inside are black, {outside - dark_outside} of {outside} "
              f"outside are lit")
        self.assertGreater(inside, 20)
        self.assertEqual(dark_outside, 0)

    def test_volume_shadows_the_floor(self):
        """The volume's light grids shade the surfaces: a floor under the slab sample (optical
        depth 2 straight down at density scale 4) lit by a vertical sun, seen from between
        them, is exp(-2) as bright as without the slab. Compared as 8-bit sRGB with the
        exposure raised by log2(e^2) on the shadowed floor, so both land mid-range."""
        scene = {"volume": {"file": sample("slab.vdb"), "density_scale": 4.0},
                 "lights": [{"type": "sun", "direction": [0, -1, 0], "irradiance": 3.0}],
                 "occluders": [{"type": "plane", "point": [0, -0.6, 0], "normal": [0, 1, 0]}]}
        values = {}
        for name, scale, ev in (("shadowed", 4.0, 2.0 / math.log(2.0)), ("open", 0.0, 0.0)):
            scene["volume"]["density_scale"] = scale
            path = self.path(name + ".json")
            with open(path, "w") as f:
                json.dump(scene, f)
            out = self.path(name + ".png")
            view(sample("slab.vdb"), "--scene", path, "--screenshot", out, "--backend", "cpu", "--camera",
                 "0,-0.35,0:0,-0.6,0:30", "--size", "8x8", "--no-interleave", "--exposure", "%.6f" % ev, "-q",
                 check=0)
            values[name] = read_png(out)[2]
        print(f"\nfloor under the slab: {values['shadowed'][:3]} (exposure +2/ln 2) against "
              f"{values['open'][:3]} without it")
        self.assertGreater(min(values["open"]), 100)
        for a, b in zip(values["shadowed"], values["open"]):
            self.assertLessEqual(abs(a - b), 2)

    def test_sample_scene(self):
        lit = self.path("occluder_lit.vdb")
        run("bake", "--scene", sample("cloud_occluder.json"), "--method", "pop", "--quality", "low", "-o", lit,
            "-q", check=0)
        out = self.path("occluder.png")
        view(lit, "--scene", sample("cloud_occluder.json"), "--screenshot", out, "--backend", "cpu", "--size",
             "64x48", "-q", check=0)
        self.assertEqual(read_png(out)[:2], (64, 48))

    def refuse_scene(self, name, needle, **extra):
        scene = write_scene(self.path(name), **extra)
        out = self.path(name + ".png")
        p = view(sample("cloud.vdb"), "--scene", scene, "--screenshot", out, display=False)
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = p.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertIn(needle, lines[0])
        self.assertFalse(os.path.exists(out))

    def test_bad_occluders(self):
        bad = self.path("bad.obj")
        with open(bad, "w") as f:
            f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
        self.refuse_scene("malformed.json", "bad.obj:4", occluders=[{"type": "obj", "file": bad}])
        self.refuse_scene("missing.json", "nothere.obj",
                          occluders=[{"type": "obj", "file": self.path("nothere.obj")}])
        self.refuse_scene("unknown.json", "colour",
                          occluders=[{"type": "sphere", "center": [0, 0, 0], "radius": 1, "colour": 1}])


class LiveInet(Base):
    """A VDB baked with inet keeps its multiple scattering live (inet_live.h): viewed with a
    moved sun, every frame runs --inet-sweeps warm sweeps from the baked lights' solution. The
    pictures after 1, 2 and 5 frames (one sweep each) against two targets: the render of a
    fresh bake for the new sun, and the viewer's own converged live picture for it (the fresh
    bake opened with its own lights given as flags, 30 frames), which leaves out the small
    difference between the bake's first scattering (cube-averaged collisions from the S1
    light grids) and the live one's (the transmittance marched from each particle)."""

    SUN = ["--sun", "-0.6,-0.6,0.5:3,2.9,2.7", "--env", "0.2,0.3,0.5"]
    SMALL = ["--size", "96x72", "--backend", "cpu", "--no-interleave", "-q"]

    def shot(self, lit, name, *extra):
        out = self.path(name + ".exr")
        p = view(lit, *self.SUN, "--screenshot", out, *self.SMALL, "--json", *extra, check=0)
        return out, json.loads(p.stdout)

    def test_light_move_converges_in_a_few_frames(self):
        lit, fresh = self.path("inet_a.vdb"), self.path("inet_b.vdb")
        bake = ["bake", "--scene", sample("cloud.json"), "--method", "inet", "--quality", "low", "-q"]
        run(*bake, "-o", lit, check=0)
        run(*bake, *self.SUN, "-o", fresh, check=0)
        baked = self.path("inet_fresh.exr")
        run("render", fresh, "--mode", "baked", "-o", baked, "--size", "96x72", "-q", check=0)
        live_target, info = self.shot(fresh, "inet_live_target", "--warmup-frames", "30")
        self.assertTrue(info["ms_live"] and info["live_converged"], info)
        errors = {}
        for frames in (1, 2, 5):
            out, info = self.shot(lit, f"inet_{frames}", "--warmup-frames", str(frames), "--inet-sweeps", "1")
            self.assertEqual((info["ms_live"], info["inet_sweeps"]), (1, 1), info)
            self.assertEqual(info["live_sweeps"], frames, info)
            errors[frames] = (relrmse(out, baked), relrmse(out, live_target), info)
        stale, info = self.shot(lit, "inet_stale", "--inet-sweeps", "0")
        self.assertEqual(info["ms_live"], 0, info)
        stale_errors = (relrmse(stale, baked), relrmse(stale, live_target))
        print("\nlive inet ms after a sun move, relative RMSE against the fresh bake's render / the "
              "converged live picture:")
        for frames, (e_bake, e_live, info) in errors.items():
            print(f"  {frames} frame(s): {e_bake:.2e} / {e_live:.2e}  (change {info['live_change']:.2e}, "
                  f"frame {info['frame_ms']:.1f} ms, sweep+ms {info['live_update_ms']:.1f} ms)")
        print(f"  stale (--inet-sweeps 0): {stale_errors[0]:.2e} / {stale_errors[1]:.2e}")
        for k in (0, 1):
            self.assertLessEqual(errors[5][k], 0.25 * stale_errors[k])
        # Against the converged live picture the error falls frame by frame; against the bake it
        # reaches the floor of the two first scatterings' difference at once.
        self.assertGreater(errors[1][1], errors[2][1])
        self.assertGreater(errors[2][1], errors[5][1])
        self.assertLessEqual(errors[5][0], 0.03)


    def test_open_from_kept_state(self):
        """A --keep-state inet bake opens from its state: the particles start from their voxels'
        stored radiance and warm line sweeps finish the opening solve (measured 5 against the
        cold open's 43 Jacobi sweeps on the cloud sample at low). Viewed with a moved sun until
        the live ms converges, the picture is the cold open's to 1e-3 (measured 2e-7)."""
        bake = ["bake", "--scene", sample("cloud.json"), "--method", "inet", "--quality", "low", "-q"]
        kept, plain = self.path("inet_kept.vdb"), self.path("inet_plain.vdb")
        run(*bake, "--keep-state", "-o", kept, check=0)
        run(*bake, "-o", plain, check=0)
        shots = {}
        for name, lit in (("state", kept), ("cold", plain)):
            shots[name] = self.shot(lit, f"inet_open_{name}", "--warmup-frames", "30")
        (state_exr, state), (cold_exr, cold) = shots["state"], shots["cold"]
        diff = relrmse(state_exr, cold_exr)
        print(f"\ninet open: from the state {state['inet_open_sweeps']} line sweeps, "
              f"{state['open_ms']:.0f} ms; cold {cold['inet_open_sweeps']} Jacobi sweeps, "
              f"{cold['open_ms']:.0f} ms; converged live pictures' relative RMSE {diff:.2e}")
        self.assertEqual((state["inet_start"], cold["inet_start"]), ("state", "cold"))
        self.assertGreater(state["inet_open_sweeps"], 0)
        self.assertLessEqual(3 * state["inet_open_sweeps"], cold["inet_open_sweeps"])
        for info in (state, cold):
            self.assertTrue(info["ms_live"] and info["live_converged"], info)
        self.assertLessEqual(diff, 1e-3)
        # A density VDB has nothing live.
        p = view(sample("cloud.vdb"), *self.SUN, "--screenshot", self.path("density.exr"),
                 *self.SMALL, "--json", check=0)
        self.assertEqual(json.loads(p.stdout)["inet_start"], "none")


class BadInput(Base):
    def refuse(self, *args, needle=None):
        out = self.path("never.png")
        p = view(*args, "--screenshot", out, display=False)
        self.assertEqual(p.returncode, 2, p.stderr)
        lines = p.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertTrue(lines[0].startswith("vdbscatter-view: "), lines[0])
        if needle:
            self.assertIn(needle, lines[0])
        self.assertFalse(os.path.exists(out))
        return lines[0]

    def test_help(self):
        p = view("--help", display=False)
        self.assertEqual(p.returncode, 0)
        self.assertIn("--screenshot", p.stdout)
        self.assertIn("keys:", p.stdout)

    def test_missing_file(self):
        self.refuse(self.path("nope.vdb"), needle="nope.vdb")

    def test_foreign_and_truncated_files(self):
        text = self.path("text.vdb")
        with open(text, "w") as f:
            f.write("not a vdb\n")
        self.refuse(text, needle="text.vdb")
        cut = self.path("cut.vdb")
        with open(sample("cloud.vdb"), "rb") as f:
            blob = f.read()
        with open(cut, "wb") as f:
            f.write(blob[:len(blob) // 2])
        self.refuse(cut, needle="cut.vdb")

    def test_bad_flags(self):
        lit = sample("cloud.vdb")
        self.refuse(lit, "--interleave", "5", needle="--interleave")
        self.refuse(lit, "--size", "0x4", needle="--size")
        self.refuse(lit, "--warp", needle="--warp")
        self.refuse(lit, "--g", "nan", needle="--g")
        self.refuse(lit, "--backend", "tpu", needle="--backend")
        self.refuse(lit, "--fog", "-1", needle="--fog")
        self.refuse(lit, "--fog", "0.2:1.5", needle="--fog")
        p = view(lit, "--screenshot", self.path("x.jpg"), display=False)
        self.assertEqual(p.returncode, 2)
        self.assertIn(".jpg", p.stderr)
        self.refuse(lit, "--inet-sweeps", "-1", needle="--inet-sweeps")
        p = view(lit, "--warmup-frames", "3", display=False)
        self.assertEqual(p.returncode, 2)
        self.assertIn("--screenshot", p.stderr)

    def test_malformed_scene(self):
        scene = self.path("bad.json")
        with open(scene, "w") as f:
            f.write('{"volume": {"file": "%s"}, "lights": [{"type": "sun", "direction": [0, -1, 0]}], '
                    '"colour": 1}' % sample("cloud.vdb"))
        self.refuse("--scene", scene, needle="colour")


if __name__ == "__main__":
    unittest.main()
