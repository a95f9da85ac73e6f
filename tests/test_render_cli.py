#!/usr/bin/python3
"""`vdbscatter render` as a pipeline meets it: help, bad flags (one line, exit 2, no image),
PNG and EXR files of the samples, the --json summary, lit VDBs (default mode, scene from
the metadata, flags on top), and baked mode of a single-scattering bake against single
mode of its input. Images are tiny (at most 64x64) and read back here by small PNG and
EXR-header parsers."""
import json
import os
import shutil
import struct
import subprocess
import tempfile
import unittest
import zlib

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def sample(name):
    return os.path.join(SAMPLES, name)


def read_png(path):
    """(width, height, flat list of 8-bit RGB values) of an 8-bit RGB PNG."""
    with open(path, "rb") as f:
        blob = f.read()
    assert blob[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, header = 8, b"", None
    while pos < len(blob):
        (length,) = struct.unpack(">I", blob[pos:pos + 4])
        kind, data = blob[pos + 4:pos + 8], blob[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", data)
        elif kind == b"IDAT":
            idat += data
        pos += 12 + length
    width, height, depth, colour = header[:4]
    assert depth == 8 and colour in (2, 6), header
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(line)
        prev = line
    rgb = []
    for line in rows:
        for x in range(width):
            rgb.extend(line[x * bpp:x * bpp + 3])
    return width, height, rgb


def exr_header(path):
    """{attribute name: (type, raw bytes)} of an OpenEXR file's header."""
    with open(path, "rb") as f:
        blob = f.read()
    assert struct.unpack("<I", blob[:4])[0] == 20000630, path
    pos, attrs = 8, {}
    while blob[pos] != 0:
        end = blob.index(b"\0", pos)
        name = blob[pos:end].decode()
        tend = blob.index(b"\0", end + 1)
        kind = blob[end + 1:tend].decode()
        (size,) = struct.unpack("<i", blob[tend + 1:tend + 5])
        attrs[name] = (kind, blob[tend + 5:tend + 5 + size])
        pos = tend + 5 + size
    return attrs


def exr_size_and_channels(path):
    attrs = exr_header(path)
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"][1])
    raw = attrs["channels"][1]
    names, pos = [], 0
    while raw[pos] != 0:
        end = raw.index(b"\0", pos)
        names.append(raw[pos:end].decode())
        pos = end + 1 + 16
    return x1 - x0 + 1, y1 - y0 + 1, names


def srgb8(linear):
    v = min(max(linear, 0.0), 1.0)
    v = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
    return int(round(255 * v))


class Base(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="vdbscatter-render-", dir=os.environ.get("VDBSCATTER_TMP"))

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_bad_input(self, args, needle):
        """Exit 2, one error line on stderr containing needle, nothing written."""
        p = run(*args)
        self.assertEqual(p.returncode, 2, f"{args}: {p.stderr}")
        lines = [l for l in p.stderr.splitlines() if l.strip() and "warning" not in l]
        self.assertEqual(len(lines), 1, f"{args}: expected one error line, got {p.stderr!r}")
        self.assertIn(needle.lower(), lines[0].lower(), f"{args}")
        self.assertEqual(os.listdir(self.dir), [], f"{args} left files")
        return lines[0]


class HelpAndFlags(Base):
    def test_help(self):
        p = run("render", "--help", check=0)
        self.assertIn("usage: vdbscatter render", p.stdout)
        for word in ["--mode", "single", "baked", "reference", "--camera", "--size", "--quality",
                     "--exposure", "--spp", "--time", "--tolerance", "--max-bounces", "--seed", "--backend", "--json",
                     "--s1", "--s1-oversample", "--env-nee", "--sky-directions"]:
            self.assertIn(word, p.stdout)
        self.assertIn("render", run("--help", check=0).stdout)

    def test_bad_flags(self):
        src = sample("cube.vdb")
        out = self.path("out.png")
        base = ["render", src, "-o", out, "--sun", "0,-1,0"]
        cases = [
            (base + ["--size", "0x5"], "--size"),
            (base + ["--size", "64"], "--size"),
            (base + ["--size", "64x-2"], "--size"),
            (base + ["--size", "20000x10"], "--size"),
            (base + ["--camera", "1,2:3,4,5:30"], "--camera"),
            (base + ["--camera", "0,0,5:0,0,0"], "--camera"),
            (base + ["--camera", "0,0,5:0,0,0:180"], "--camera"),
            (base + ["--camera", "0,0,5:0,0,0:x"], "--camera"),
            (base + ["--camera", "1,1,1:1,1,1:30"], "--camera"),
            (base + ["--mode", "bogus"], "--mode"),
            (base + ["--exposure", "nan"], "--exposure"),
            (base + ["--backend", "tpu"], "--backend"),
            (base + ["--spp", "0"], "--spp"),
            (base + ["--time", "-1"], "--time"),
            (base + ["--tolerance", "0"], "--tolerance"),
            (base + ["--tolerance", "1"], "--tolerance"),
            (base + ["--tolerance", "5%"], "--tolerance"),
            (base + ["--max-bounces", "0"], "--max-bounces"),
            (base + ["--seed", "-3"], "--seed"),
            (base + ["--quality", "extreme"], "quality"),
            (base + ["--s1", "cone"], "--s1"),
            (base + ["--env-nee", "maybe"], "--env-nee"),
            (base + ["--sky-directions", "0"], "--sky-directions"),
            (base + ["--s1-oversample", "0"], "--s1-oversample"),
            (base + ["--s1-oversample", "17"], "--s1-oversample"),
            (base + ["--g", "1"], "g"),
            (base + ["--frobnicate"], "--frobnicate"),
            (base + ["--mode", "baked"], "lit"),
            (["render", src, "-o", out], "light"),
            (["render", src, "--sun", "0,-1,0"], "-o"),
            (["render", src, "-o", self.path("out.jpg"), "--sun", "0,-1,0"], "jpg"),
            (["render", self.path("missing.vdb"), "-o", out, "--sun", "0,-1,0"], "missing.vdb"),
            (["render", src, "-o", self.path("nodir/out.png"), "--sun", "0,-1,0"], "exist"),
        ]
        for args, needle in cases:
            with self.subTest(args=args):
                self.assert_bad_input(args, needle)


class Images(Base):
    def test_png_and_exr_of_a_sample(self):
        png, exr = self.path("cube.png"), self.path("cube.exr")
        common = ["--scene", sample("cube.json"), "--size", "32x24", "--quality", "low"]
        p = run("render", sample("cube.vdb"), "-o", png, *common, check=0)
        self.assertEqual(p.stdout, "")
        lines = p.stderr.strip().splitlines()
        # off a terminal: timestamped log lines (docs/sequences.md "Logs"), never a '\r'
        # line, then the summary
        self.assertNotIn("\r", p.stderr)
        stamp = r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ render: render: "
        self.assertRegex(lines[0], stamp + "started$")
        self.assertRegex(lines[-2], stamp + r"done in [0-9.]+s$")
        self.assertIn("rendered 32x24", lines[-1])
        p = run("render", sample("cube.vdb"), "-o", png, *common, "--progress", "none", check=0)
        lines = p.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, p.stderr)  # the summary alone
        self.assertIn("rendered 32x24", lines[0])
        width, height, rgb = read_png(png)
        self.assertEqual((width, height), (32, 24))
        self.assertGreater(len(set(rgb)), 10)  # a picture, not a flat colour
        p = run("render", sample("cube.vdb"), "-o", exr, *common, "-q", check=0)
        self.assertEqual(p.stderr, "")
        width, height, channels = exr_size_and_channels(exr)
        self.assertEqual((width, height), (32, 24))
        self.assertEqual(sorted(channels), ["B", "G", "R"])
        self.assertEqual([f for f in os.listdir(self.dir) if "tmp" in f], [])

    def test_empty_medium_is_the_env_colour(self):
        png = self.path("env.png")
        run("render", sample("cloud.vdb"), "-o", png, "--density-scale", "0", "--env", "0.2,0.3,0.5",
            "--sun", "0,-1,0:5", "--size", "16x12", "-q", check=0)
        _, _, rgb = read_png(png)
        want = [srgb8(0.2), srgb8(0.3), srgb8(0.5)]
        self.assertEqual(rgb, want * (16 * 12))
        # Exposure scales the linear values before the encoding.
        run("render", sample("cloud.vdb"), "-o", png, "--density-scale", "0", "--env", "0.1,0.15,0.25",
            "--sun", "0,-1,0", "--size", "16x12", "--exposure", "1", "-q", check=0)
        _, _, rgb = read_png(png)
        self.assertEqual(rgb[:3], want)

    def test_json_summary(self):
        out = self.path("slab.exr")
        p = run("render", sample("slab.vdb"), "--scene", sample("slab.json"), "-o", out, "--size", "20x16",
                "--quality", "low", "--backend", "cpu", "--json", check=0)
        j = json.loads(p.stdout)
        self.assertEqual(j["mode"], "single")
        self.assertEqual((j["width"], j["height"]), (20, 16))
        self.assertEqual(j["backend"], "cpu")
        self.assertEqual(j["spp"], 1)
        self.assertEqual(j["quality"], "low")
        self.assertEqual(j["sky_directions"], 16)
        self.assertEqual(j["step_voxels"], 1)
        self.assertEqual(j["output"], out)
        for key in ["load", "render", "write", "total"]:
            self.assertGreaterEqual(j["seconds"][key], 0.0)
        self.assertEqual(j["camera"]["position"], [0.0, 3.0, 3.0])  # from the scene file
        self.assertTrue(os.path.exists(out))
        self.assertEqual(j["input"], sample("slab.vdb"))
        # Without IN.vdb the input is the scene's volume file (it once read freed memory).
        p = run("render", "--scene", sample("slab.json"), "-o", out, "--size", "4x4", "--quality", "low",
                "--json", check=0)
        self.assertEqual(os.path.realpath(json.loads(p.stdout)["input"]), os.path.realpath(sample("slab.vdb")))

    def test_camera_flag_and_vertical_view(self):
        out = self.path("top.png")
        p = run("render", sample("slab.vdb"), "--scene", sample("slab.json"), "-o", out, "--size", "8x8",
                "--camera", "0,3,0:0,0,0:20", "--quality", "low", "--json", check=0)
        j = json.loads(p.stdout)
        self.assertEqual(j["camera"]["position"], [0.0, 3.0, 0.0])
        self.assertEqual(j["camera"]["up"], [0.0, 0.0, -1.0])
        _, _, rgb = read_png(out)
        self.assertEqual(len(set(rgb)), 1)  # a laterally uniform slab seen from above

    def test_reference_mode(self):
        out = self.path("ref.exr")
        p = run("render", sample("cube.vdb"), "--scene", sample("cube.json"), "-o", out, "--size", "12x10",
                "--mode", "reference", "--spp", "2", "--max-bounces", "3", "--seed", "7", "--json", check=0)
        j = json.loads(p.stdout)
        self.assertEqual(j["mode"], "reference")
        self.assertEqual(j["spp"], 2)
        self.assertEqual(j["max_bounces"], 3)
        self.assertEqual(j["seed"], 7)
        _, _, channels = exr_size_and_channels(out)
        self.assertEqual(sorted(channels), ["B", "G", "R", "se.B", "se.G", "se.R"])

    def test_reference_to_a_tolerance(self):
        """--tolerance E renders until the image's relative noise is at most E; that noise is
        the image's real error: against an independent, four times less noisy render the
        relative RMSE is sqrt(E_a^2 + E_b^2) up to the noise of its own estimate (over 2304
        pixel values, a few percent; the bounds leave +-30%). A time cap stops it first."""
        def render(name, tolerance, seed, *extra):
            p = run("render", sample("sphere.vdb"), "--scene", sample("sphere.json"), "-o", self.path(name),
                    "--size", "32x24", "--mode", "reference", "--tolerance", tolerance, "--seed", seed,
                    "--json", *extra, check=0)
            return json.loads(p.stdout)
        a = render("a.exr", 0.04, 3)
        b = render("b.exr", 0.01, 4)
        for j, tol in ((a, 0.04), (b, 0.01)):
            self.assertLessEqual(j["noise"], tol)
            self.assertGreater(j["noise"], 0.6 * tol)  # the rounds stop near it, not far past
            self.assertEqual(j["tolerance"], tol)
        self.assertGreater(b["spp"], 8 * a["spp"])
        c = json.loads(run("compare", self.path("a.exr"), self.path("b.exr"), "--json", check=0).stdout)
        expect = (a["noise"] ** 2 + b["noise"] ** 2) ** 0.5
        self.assertAlmostEqual(c["se_a"], a["noise"], places=6)
        self.assertGreater(c["relrmse"], 0.7 * expect)
        self.assertLess(c["relrmse"], 1.3 * expect)
        capped = render("c.exr", 0.0005, 5, "--time", "1")
        self.assertGreater(capped["noise"], 0.0005)
        self.assertLess(capped["seconds"]["render"], 3.0)


class LitInput(Base):
    def bake(self, *extra):
        lit = self.path("lit.vdb")
        run("bake", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--quality", "low", "-o", lit, "-q",
            *extra, check=0)
        return lit

    def compare(self, a, b):
        p = run("compare", a, b, "--json")
        if p.returncode != 0:
            self.skipTest(f"vdbscatter compare is not available: {p.stderr.strip()}")
        return json.loads(p.stdout)

    def test_baked_single_bake_equals_single(self):
        lit = self.bake("--method", "single")
        baked, single = self.path("baked.exr"), self.path("single.exr")
        p = run("render", lit, "-o", baked, "--size", "40x30", "--json", check=0)
        j = json.loads(p.stdout)
        self.assertEqual(j["mode"], "baked")  # the default for a lit VDB
        self.assertEqual(j["quality"], "low")  # from its scene metadata
        self.assertEqual(j["grid"], "density")
        run("render", sample("cloud.vdb"), "--scene", sample("cloud.json"), "--quality", "low", "-o", single,
            "--size", "40x30", "-q", check=0)
        metrics = self.compare(baked, single)
        self.assertLessEqual(metrics["relrmse"], 1e-3)

    def test_baked_grids_match_marches(self):
        """render --mode baked --relight with light grids (the default) against the exact light
        marches (--s1 march) on the cloud sample, sun + sky, g = 0.85: within 1% relative RMSE;
        the summary gives the grids' sizes and the stages' times."""
        lit = self.bake()
        grids, marches = self.path("grids.exr"), self.path("marches.exr")
        p = run("render", lit, "-o", grids, "--size", "64x48", "--json", "--relight", check=0)
        j = json.loads(p.stdout)
        # the lit VDB was baked at low: its quality's one sample per voxel
        self.assertEqual((j["mode"], j["s1"], j["s1_oversample"]), ("baked", "grid", 1))
        self.assertGreater(j["light_grids"]["columns"], j["light_grids"]["columns_empty"])
        self.assertGreater(j["light_grids"]["samples_stored"], 0)
        self.assertLessEqual(j["seconds"]["s1_sweep"] + j["seconds"]["march"], j["seconds"]["render"])
        p = run("render", lit, "-o", marches, "--size", "64x48", "--s1", "march", "--json", "--relight",
                check=0)
        j = json.loads(p.stdout)
        self.assertEqual(j["s1"], "march")
        self.assertNotIn("light_grids", j)
        metrics = self.compare(grids, marches)
        print(f"\nbaked cloud, light grids against light marches: relative RMSE {metrics['relrmse']:.2e}")
        self.assertLessEqual(metrics["relrmse"], 0.01)

    def test_flags_override_the_baked_scene(self):
        lit = self.bake()
        png = self.path("flat.png")
        run("render", lit, "-o", png, "--size", "8x6", "--density-scale", "0", "--env", "0.2,0.3,0.5",
            "-q", "--relight", check=0)
        _, _, rgb = read_png(png)
        self.assertEqual(rgb, [srgb8(0.2), srgb8(0.3), srgb8(0.5)] * 48)
        p = run("render", lit, "-o", self.path("single.exr"), "--size", "8x6", "--mode", "single", "--json",
                check=0)
        self.assertEqual(json.loads(p.stdout)["mode"], "single")

    def test_scene_file_of_a_bake_with_sky_directions(self):
        """A lit VDB baked from a scene file with --sky-directions on top renders with that same
        file: the file leaves the sky's ordinates to the bake (the image is the one rendered
        from the lit VDB alone), while a file that sets other ones is refused."""
        lit = self.bake("--sky-directions", "8")
        alone, with_file = self.path("alone.exr"), self.path("file.exr")
        run("render", lit, "-o", alone, "--size", "24x18", "-q", check=0)
        p = run("render", lit, "--scene", sample("cloud.json"), "-o", with_file, "--size", "24x18",
                "--json", check=0)
        self.assertEqual(json.loads(p.stdout)["sky_directions"], 8)
        self.assertEqual(self.compare(with_file, alone)["relrmse"], 0.0)
        scene = self.path("scene.json")
        with open(sample("cloud.json")) as f:
            text = json.load(f)
        text["volume"]["file"] = sample("cloud.vdb")
        text["solver"] = {"sky_directions": 32}
        with open(scene, "w") as f:
            json.dump(text, f)
        p = run("render", lit, "--scene", scene, "-o", self.path("other.exr"), "--size", "24x18")
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("differ", p.stderr)

    def test_scene_file_with_an_automatic_density_scale(self):
        """A scene file whose density scale is auto:TAU renders the lit VDB it baked: the same
        TAU on the same grid is the same medium (the image is the one rendered from the lit VDB
        alone), while another TAU is refused."""
        def scene_with(tau):
            path = self.path(f"auto{tau}.json")
            with open(sample("cloud.json")) as f:
                text = json.load(f)
            text["volume"]["file"] = sample("cloud.vdb")
            text["volume"]["density_scale"] = f"auto:{tau}"
            with open(path, "w") as f:
                json.dump(text, f)
            return path
        lit = self.path("lit.vdb")
        run("bake", "--scene", scene_with(8), "--quality", "low", "-o", lit, "-q", check=0)
        alone, with_file = self.path("alone.exr"), self.path("file.exr")
        run("render", lit, "-o", alone, "--size", "24x18", "-q", check=0)
        run("render", lit, "--scene", scene_with(8), "-o", with_file, "--size", "24x18", "-q",
            check=0)
        self.assertEqual(self.compare(with_file, alone)["relrmse"], 0.0)
        p = run("render", lit, "--scene", scene_with(4), "-o", self.path("other.exr"), "--size",
                "24x18")
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("differ", p.stderr)
        self.assertFalse(os.path.exists(self.path("other.exr")))


class GpuBackend(Base):
    def test_gpu_matches_cpu(self):
        cpu, gpu = self.path("cpu.exr"), self.path("gpu.exr")
        common = [sample("smoke.vdb"), "--scene", sample("smoke.json"), "--size", "16x12", "--quality", "low",
                  "-q"]
        run("render", *common, "-o", cpu, "--backend", "cpu", check=0)
        p = run("render", *common, "-o", gpu, "--backend", "gpu")
        if p.returncode != 0:
            self.skipTest(f"no GL context: {p.stderr.strip()}")
        p = run("compare", gpu, cpu, "--json")
        if p.returncode != 0:
            self.skipTest("vdbscatter compare is not available")
        self.assertLess(json.loads(p.stdout)["relrmse"], 1e-5)

    def test_gpu_matches_cpu_from_stored_depths(self):
        """A lit VDB's stored depths (a sun's and an ordinate's light-frame grids, a point light's
        radial grid) read by the shader as by the C path."""
        lit = self.path("lit.vdb")
        run("bake", sample("smoke.vdb"), "--scene", sample("smoke.json"), "--quality", "low", "--method",
            "single", "--env", "0.2,0.3,0.4", "--sun", "0.3,-1,0.2", "--point", "0.2,0.9,0.1:2,2,2", "-o", lit,
            "-q", check=0)
        cpu, gpu = self.path("cpu.exr"), self.path("gpu.exr")
        common = [lit, "--size", "16x12", "--json"]
        self.assertEqual(json.loads(run("render", *common, "-o", cpu, "--backend", "cpu", check=0).stdout)["s1"],
                         "stored")
        p = run("render", *common, "-o", gpu, "--backend", "gpu")
        if p.returncode != 0:
            self.skipTest(f"no GL context: {p.stderr.strip()}")
        self.assertEqual(json.loads(p.stdout)["s1"], "stored")
        p = run("compare", gpu, cpu, "--json", check=0)
        self.assertLess(json.loads(p.stdout)["relrmse"], 1e-5)


if __name__ == "__main__":
    unittest.main()
