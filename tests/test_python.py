#!/usr/bin/python3
"""The Python package (python/vdbscatter: ctypes over libvdbscatter.so) against the CLI:
each binding returns what the CLI prints for the same command line, keywords translate to
the command lines the CLI is given, errors carry the library's own message, Ctrl-C leaves no
file, pictures equal the EXR files bit for bit, and read_lit's arrays agree with `info` and
pyopenvdb.

Environment: VDBSCATTER (the CLI), VDBSCATTER_LIBRARY (default: libvdbscatter.so.0 beside the
CLI), VDBSCATTER_PYTHONPATH (default: the repository's python/ folder), VDBSCATTER_TMP. The
whole file is skipped when the library is not built."""
import contextlib
import ctypes.util
import json
import os
import pty
import re
import resource
import select
import shlex
import shutil
import signal
import struct
import subprocess
import sys
import sysconfig
import tempfile
import threading
import _thread
import time
import unittest
import warnings
import zlib

# OpenBLAS loaded by dlopen (as ctypes loads the library) rounds the phase matrix's
# eigendecomposition differently from OpenBLAS linked at start-up (the CLI) when it runs
# threaded: the reports' svd.factor_rmse differ in the last bits. One thread, in this process
# and the CLI's, makes the two comparable bit for bit. Set before numpy loads OpenBLAS.
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.abspath(os.environ["VDBSCATTER"])
TMP = os.environ.get("VDBSCATTER_TMP") or None
LIBRARY = os.environ.get("VDBSCATTER_LIBRARY") or os.path.join(os.path.dirname(EXE),
                                                               "libvdbscatter.so.0")
PYTHONPATH = os.environ.get("VDBSCATTER_PYTHONPATH") or os.path.join(ROOT, "python")
COMMANDS = ["bake", "render", "compare", "info", "sample", "tradeoff", "phase-svd"]
FLAG = re.compile(r"(?<![\w-])(--[a-z0-9][a-z0-9-]*|-o|-q)(?![\w-])")

if os.path.isfile(LIBRARY):
    os.environ["VDBSCATTER_LIBRARY"] = LIBRARY
    sys.path.insert(0, PYTHONPATH)
    import vdbscatter
else:
    vdbscatter = None


def setUpModule():
    if vdbscatter is None:
        raise unittest.SkipTest(f"no {LIBRARY} (build the target vdbscatter_shared)")
    global WORK, CLOUD, BIG, LIT, SKY
    if TMP:
        os.makedirs(TMP, exist_ok=True)
    WORK = tempfile.mkdtemp(prefix="vdbscatter-python-", dir=TMP)
    unittest.addModuleCleanup(shutil.rmtree, WORK, ignore_errors=True)
    CLOUD = os.path.join(WORK, "cloud16.vdb")
    BIG = os.path.join(WORK, "cloud96.vdb")
    LIT = os.path.join(WORK, "lit16.vdb")
    SKY = os.path.join(WORK, "sky.exr")
    cli("sample", "cloud", "-o", CLOUD, "--res", "16")
    cli("sample", "cloud", "-o", BIG, "--res", "96")
    cli("sample", "sky", "-o", SKY, "--res", "8")
    cli("bake", CLOUD, "-o", LIT, "--sun", "0.3,-1,0.2", "-q")


def cli(*args, check=0, cwd=None, preexec_fn=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600,
                       cwd=cwd, preexec_fn=preexec_fn)
    if check is not None and p.returncode != check:
        raise AssertionError(f"vdbscatter {args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def cli_json(*args, cwd=None):
    return json.loads(cli(*args, "--json", cwd=cwd).stdout)


def cli_error(*args):
    """The message of a CLI run that fails with bad input: its one stderr line without the
    'vdbscatter COMMAND: ' prefix."""
    p = cli(*args, check=2)
    line, = p.stderr.splitlines()
    prefix = f"vdbscatter {args[0]}: "
    assert line.startswith(prefix), line
    return line[len(prefix):]


def python_env():
    env = dict(os.environ)
    env["VDBSCATTER_LIBRARY"] = LIBRARY
    env["PYTHONPATH"] = PYTHONPATH
    return env


def python_m(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "vdbscatter", *map(str, args)],
                          capture_output=True, text=True, timeout=600, cwd=cwd,
                          env=python_env())


# Keys of a report that differ between two runs of one command line: times, memory, bytes,
# and tradeoff's Pareto marks (where two methods' errors tie, the faster one's).
def volatile(key):
    return (key in ("seconds", "memory", "transfer", "peak_mib", "pareto")
            or key.startswith("seconds_")
            or key.endswith("_seconds") or key.endswith("_s") or key.endswith("_bytes"))


def stable(report):
    if isinstance(report, dict):
        return {k: stable(v) for k, v in report.items() if not volatile(k)}
    if isinstance(report, list):
        return [stable(v) for v in report]
    return report


def differences(a, b, path="report"):
    """Where two JSON values differ, one line each."""
    if isinstance(a, dict) and isinstance(b, dict):
        lines = [f"{path}.{k}: only in the first" for k in a.keys() - b.keys()]
        lines += [f"{path}.{k}: only in the second" for k in b.keys() - a.keys()]
        for k in a.keys() & b.keys():
            lines += differences(a[k], b[k], f"{path}.{k}")
        return lines
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [line for i, (x, y) in enumerate(zip(a, b))
                for line in differences(x, y, f"{path}[{i}]")]
    return [] if a == b else [f"{path}: {a!r} != {b!r}"]


def read_exr(path):
    """{channel: (H, W) float32} of a scanline OpenEXR file, uncompressed, ZIPS or ZIP,
    decoded here in pure Python (independent of the OpenEXR library the tool writes with)."""
    with open(path, "rb") as f:
        blob = f.read()
    assert struct.unpack_from("<I", blob)[0] == 20000630, path
    pos, attrs = 8, {}
    while blob[pos] != 0:
        end = blob.index(b"\0", pos)
        tend = blob.index(b"\0", end + 1)
        size, = struct.unpack_from("<i", blob, tend + 1)
        attrs[blob[pos:end].decode()] = blob[tend + 5:tend + 5 + size]
        pos = tend + 5 + size
    pos += 1
    channels, raw, at = [], attrs["channels"], 0
    while raw[at] != 0:
        end = raw.index(b"\0", at)
        ptype, = struct.unpack_from("<i", raw, end + 1)
        channels.append((raw[at:end].decode(), {1: "<f2", 2: "<f4"}[ptype]))
        at = end + 17
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    lines = {0: 1, 2: 1, 3: 16}[attrs["compression"][0]]
    chunks = (height + lines - 1) // lines
    image = {name: np.zeros((height, width), np.float32) for name, _ in channels}
    for offset in struct.unpack_from(f"<{chunks}Q", blob, pos):
        y, size = struct.unpack_from("<ii", blob, offset)
        data = blob[offset + 8:offset + 8 + size]
        rows = min(lines, y1 + 1 - y)
        expected = rows * width * sum(np.dtype(t).itemsize for _, t in channels)
        if size < expected:  # ZIP: zlib, a byte delta predictor, even/odd halves
            d = np.frombuffer(zlib.decompress(data), np.uint8).astype(np.int64)
            t = (np.cumsum(np.concatenate(([d[0]], d[1:] - 128))) & 0xFF).astype(np.uint8)
            half = (len(t) + 1) // 2
            data = np.empty(len(t), np.uint8)
            data[0::2], data[1::2] = t[:half], t[half:]
            data = data.tobytes()
        at = 0
        for r in range(rows):
            for name, kind in channels:
                image[name][y - y0 + r] = np.frombuffer(data, kind, width, at)
                at += width * np.dtype(kind).itemsize
    return image


def exr_rgb(image, prefix=""):
    return np.stack([image[prefix + c] for c in "RGB"], axis=-1)


def assert_bits_equal(test, a, b, what):
    test.assertEqual(a.shape, b.shape, what)
    same = a.view(np.uint32) == b.view(np.uint32)
    test.assertTrue(same.all(), f"{what}: {np.count_nonzero(~same)} of {a.size} values differ")


class Base(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="case-", dir=WORK)

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_same_report(self, cli_report, py_report, what):
        lines = differences(stable(cli_report), stable(py_report))
        self.assertEqual(lines, [], f"{what}: the CLI's report (first) and Python's differ:\n"
                         + "\n".join(lines))

    @contextlib.contextmanager
    def inside(self, folder):
        old = os.getcwd()
        os.chdir(folder)
        try:
            yield
        finally:
            os.chdir(old)


# A scene with a relative volume path: as a file (scene.json) and as a dict.
SCENE = {"volume": {"file": "cloud16.vdb", "density_scale": 4, "albedo": [0.9, 0.9, 0.9]},
         "lights": [{"type": "sun", "direction": [0.3, -1.0, 0.2], "irradiance": [2, 2, 2]},
                    {"type": "env", "color": [0.2, 0.3, 0.5]}],
         "camera": {"position": [0, 0.6, 4.5], "target": [0, 0, 0], "fov_deg": 35,
                    "width": 32, "height": 24}}

# (bake's flags, the same as keywords), run in a folder holding the 16^3 cloud as
# cloud16.vdb, the sky map sky.exr and SCENE as scene.json.
BAKES = [
    ("--sun 0,-1,0", dict(sun=(0, -1, 0))),
    ("--sun 0.3,-1,0.2:3,3,3", dict(sun=((0.3, -1, 0.2), (3, 3, 3)))),
    ("--sun 0,-1,0 --sun 1,0,0:0.5,0.25,0.125",
     dict(sun=[(0, -1, 0), ((1, 0, 0), (0.5, 0.25, 0.125))])),
    ("--point 0,2,0:5,5,5", dict(point=((0, 2, 0), (5, 5, 5)))),
    ("--point 0.5,1.5,0 --point -0.5,1.5,0:2,1,1 --env 0.1,0.1,0.1 --s1 march",
     dict(point=[(0.5, 1.5, 0), ((-0.5, 1.5, 0), (2, 1, 1))], env=[0.1, 0.1, 0.1],
          s1="march")),
    ("--env 0.2,0.3,0.5", dict(env=(0.2, 0.3, 0.5))),
    ("--env 0.2,0.3,0.5 --sky-directions 8", dict(env=[(0.2, 0.3, 0.5)], sky_directions=8)),
    ("--env sky.exr:0.5", dict(env=("sky.exr", 0.5))),
    ("--sun 0,-1,0 --method single", dict(sun=(0, -1, 0), method="single")),
    ("--sun 0,-1,0 --env 0.2,0.2,0.2 --method pop --pop-res 6",
     dict(sun=(0, -1, 0), env=(0.2, 0.2, 0.2), method="pop", pop_res=6)),
    ("--sun 0,-1,0 --method fld --fld-limiter off --fld-res 12",
     dict(sun=(0, -1, 0), method="fld", fld_limiter="off", fld_res=12)),
    ("--sun 0,-1,0 --method svd --quality medium --keep-state",
     dict(sun=(0, -1, 0), method="svd", quality="medium", keep_state=True)),
    ("--sun 0,-1,0 --albedo 0.9,0.8,0.7 --g 0.6",
     dict(sun=(0, -1, 0), albedo=(0.9, 0.8, 0.7), g=0.6)),
    ("--sun 0,-1,0 --density-scale auto:10", dict(sun=(0, -1, 0), density_scale="auto:10")),
    ("--sun 0,-1,0 --density-scale 12.5 --albedo 0.3",
     dict(sun=(0, -1, 0), density_scale=12.5, albedo=0.3)),
    ("--sun 0,-1,0 --store none", dict(sun=(0, -1, 0), store="none", half=False)),
    ("--sun 0,-1,0 --half", dict(sun=(0, -1, 0), half=True)),
    ("--sun 0,-1,0 --camera 0,0,5:0,0,0:35",
     dict(sun=(0, -1, 0), camera=((0, 0, 5), (0, 0, 0), 35))),
    ("--scene scene.json", dict(scene="scene.json")),
    ("--scene scene.json --albedo 0.7 --g=-0.3", dict(scene=SCENE, albedo=0.7, g=-0.3)),
    ("--sun 0,-1,0 --quality high --method svd --svd-directions 32 --residual 0.1",
     dict(sun=np.array([0.0, -1.0, 0.0]), quality="high", method="svd", svd_directions=32,
          residual=0.1)),
]


class Translation(Base):
    def test_bake_reports_match_the_cli(self):
        """Each command line's --json report from the CLI equals bake(**keywords)'s, but for
        times, memory and byte counts, and the two lit VDBs hold the same grids and value
        ranges (what --half and --keep-state change): the keywords say what the flags say."""
        shutil.copy(CLOUD, self.path("cloud16.vdb"))
        shutil.copy(SKY, self.path("sky.exr"))
        with open(self.path("scene.json"), "w") as f:
            json.dump(SCENE, f)
        for flags, keywords in BAKES:
            with self.subTest(flags=flags):
                expected = cli_json("bake", "cloud16.vdb", "-o", "cli.vdb", *shlex.split(flags),
                                    cwd=self.dir)
                with self.inside(self.dir):
                    got = vdbscatter.bake("cloud16.vdb", "py.vdb", **keywords)
                self.assertEqual((expected.pop("output"), got.pop("output")),
                                 ("cli.vdb", "py.vdb"))
                self.assert_same_report(expected, got, flags)
                theirs = vdbscatter.info(self.path("cli.vdb"))
                ours = vdbscatter.info(self.path("py.vdb"))
                theirs.pop("file"), ours.pop("file")
                self.assertEqual(ours, theirs, flags)
        # A scene dict's temporary file is gone, and nothing else was left.
        self.assertEqual(sorted(os.listdir(self.dir)),
                         ["cli.vdb", "cloud16.vdb", "py.vdb", "scene.json", "sky.exr"])

    def test_scene_dict_names_the_volume(self):
        """Without IN, the dict's relative volume path is relative to the current folder, as
        a scene file's is to its folder."""
        shutil.copy(CLOUD, self.path("cloud16.vdb"))
        with open(self.path("scene.json"), "w") as f:
            json.dump(SCENE, f)
        expected = cli_json("bake", "--scene", "scene.json", "-o", "lit.vdb", cwd=self.dir)
        with self.inside(self.dir):
            got = vdbscatter.bake(None, "lit.vdb", scene=SCENE)
        self.assert_same_report(expected, got, "scene dict")
        self.assertEqual(sorted(os.listdir(self.dir)), ["cloud16.vdb", "lit.vdb", "scene.json"])

    def test_values_as_the_cli_reads_them(self):
        """The text of keyword values (the syntax of --help)."""
        words = vdbscatter._option_words
        self.assertEqual(words("bake", dict(sun=((0.3, -1, 0.2), (3, 3, 3)))),
                         ["--sun", "0.3,-1,0.2:3,3,3"])
        self.assertEqual(words("bake", dict(camera=((0, 0, 5), (0, 0, 0), 35))),
                         ["--camera", "0,0,5:0,0,0:35"])
        self.assertEqual(words("render", dict(size=(640, 480), output="a.exr", q=True)),
                         ["--size", "640x480", "-o", "a.exr", "-q"])
        self.assertEqual(words("bake", dict(point=[(0, 1, 0), (1, 0, 0)], half=False)),
                         ["--point", "0,1,0", "--point", "1,0,0"])
        self.assertEqual(words("tradeoff", dict(methods=("svd", "pop"))),
                         ["--methods", "svd,pop"])
        self.assertEqual(words("bake", dict(env=(SKY, 2), density_scale=None)),
                         ["--env", SKY + ":2"])
        # Floats keep every bit.
        text, = words("bake", dict(g=1 / 3))[1:]
        self.assertEqual(float(text), 1 / 3)

    def test_keywords_are_the_help_flags(self):
        """Every option of the library's table is a flag the command's --help prints, and
        its keyword is the flag with dashes as underscores."""
        for command in COMMANDS:
            with self.subTest(command=command):
                printed = set(FLAG.findall(cli(command, "--help").stdout))
                table = vdbscatter._OPTIONS[command]
                self.assertGreater(len(table), 0)
                for keyword, (flag, kind) in table.items():
                    self.assertIn(flag, printed)
                    if keyword != "output":
                        self.assertEqual(keyword, flag.lstrip("-").replace("-", "_"))
                self.assertEqual(table.get("output", (None,))[0], table.get("o", (None,))[0])


class Bindings(Base):
    def test_sample_and_info(self):
        """sample writes what the CLI writes (info reads the same), and info returns the
        CLI's JSON."""
        for name, extra in [("sphere", {}), ("cloud", {"seed": 3})]:
            with self.subTest(name=name):
                ours, theirs = self.path(f"{name}-py.vdb"), self.path(f"{name}-cli.vdb")
                self.assertIsNone(vdbscatter.sample(name, ours, res=12, **extra))
                cli("sample", name, "-o", theirs, "--res", "12",
                    *[w for k, v in extra.items() for w in (f"--{k}", v)])
                a, b = vdbscatter.info(ours), vdbscatter.info(theirs)
                self.assertEqual((a.pop("file"), b.pop("file")), (ours, theirs))
                self.assertEqual(a, b)
        self.assertEqual(vdbscatter.info(LIT), cli_json("info", LIT))
        self.assertEqual(vdbscatter.info(CLOUD, density_scale=2.5, target_depth=10),
                         cli_json("info", CLOUD, "--density-scale", "2.5", "--target-depth", "10"))

    def test_phase_svd(self):
        self.assertEqual(vdbscatter.phase_svd(g=0.5, directions=16),
                         cli_json("phase-svd", "--g", "0.5", "--directions", "16"))

    def test_compare(self):
        a, b = self.path("a.exr"), self.path("b.exr")
        cli("render", LIT, "-o", a, "--size", "16x12", "-q")
        cli("render", LIT, "-o", b, "--size", "16x12", "--mode", "single", "-q")
        self.assertEqual(vdbscatter.compare(a, b), cli_json("compare", a, b))
        self.assertEqual(vdbscatter.compare(a, b, mask_below=0.01),
                         cli_json("compare", a, b, "--mask-below", "0.01"))

    def test_tradeoff(self):
        """A small tradeoff (two methods, one quality, an 8x6 picture, a noisy reference)
        measures what the CLI's measures."""
        words = ["--sun", "0,-1,0", "--methods", "single,svd", "--qualities", "low",
                 "--size", "8x6", "--ref-noise", "0.2"]
        expected = cli_json("tradeoff", CLOUD, "-o", "cli", *words, cwd=self.dir)
        with self.inside(self.dir):
            got = vdbscatter.tradeoff(CLOUD, "py", sun=(0, -1, 0), methods=("single", "svd"),
                                      qualities="low", size=(8, 6), ref_noise=0.2)
        files = got.pop("files")
        self.assertEqual(files, {k: v.replace("cli/", "py/", 1)
                                 for k, v in expected.pop("files").items()})
        for path in files.values():
            self.assertTrue(os.path.isfile(self.path(path)), path)
        self.assertEqual(len(got["rows"]), 2)
        self.assert_same_report(expected, got, "tradeoff --json")

    def test_render_equals_its_exr(self):
        """The array equals the EXR written with it and the CLI's EXR, bit for bit; without
        output= the same picture comes back and no file is written."""
        ours, theirs = self.path("py.exr"), self.path("cli.exr")
        image = vdbscatter.render(LIT, ours, size=(16, 12))
        cli("render", LIT, "-o", theirs, "--size", "16x12")
        self.assertEqual(image.dtype, np.float32)
        assert_bits_equal(self, image, exr_rgb(read_exr(ours)), "render -o py.exr")
        assert_bits_equal(self, image, exr_rgb(read_exr(theirs)), "the CLI's render")
        with self.inside(self.dir):
            again = vdbscatter.render(LIT, size=(16, 12))
        assert_bits_equal(self, again, image, "render without output")
        self.assertEqual(sorted(os.listdir(self.dir)), ["cli.exr", "py.exr"])

    def test_reference_render_and_its_standard_errors(self):
        ours, theirs = self.path("py.exr"), self.path("cli.exr")
        words = ["--mode", "reference", "--spp", "4", "--sun", "0,-1,0", "--size", "12x8",
                 "--density-scale", "8"]
        rgb, se = vdbscatter.render(CLOUD, ours, mode="reference", spp=4, sun=(0, -1, 0),
                                    size=(12, 8), density_scale=8, return_se=True)
        cli("render", CLOUD, "-o", theirs, *words)
        for path in (ours, theirs):
            exr = read_exr(path)
            assert_bits_equal(self, rgb, exr_rgb(exr), path)
            assert_bits_equal(self, se, exr_rgb(exr, "se."), path + " se")
        self.assertGreater(se.max(), 0)
        # Modes without standard errors return None for them.
        image, none = vdbscatter.render(LIT, size=(8, 6), return_se=True)
        self.assertIsNone(none)
        self.assertEqual(image.shape, (6, 8, 3))

    def test_render_report(self):
        out = self.path("p.exr")
        expected = cli_json("render", LIT, "-o", out, "--size", "16x12")
        image, report = vdbscatter.render(LIT, out, size=(16, 12), return_report=True)
        self.assertEqual(image.shape, (12, 16, 3))
        self.assert_same_report(expected, report, "render --json")

    def test_warnings(self):
        """A warning arrives as a VdbscatterWarning with the CLI's text."""
        p = cli("render", CLOUD, "-o", self.path("a.exr"), "--sun", "0,-1,0", "--size", "8x6",
                "--spp", "4")
        expected = [line[len("vdbscatter: warning: "):] for line in p.stderr.splitlines()
                    if line.startswith("vdbscatter: warning: ")]
        self.assertEqual(len(expected), 1, p.stderr)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            vdbscatter.render(CLOUD, sun=(0, -1, 0), size=(8, 6), spp=4)
        self.assertEqual([str(w.message) for w in caught], expected)
        self.assertTrue(all(w.category is vdbscatter.VdbscatterWarning for w in caught))

    def test_progress(self):
        """progress= receives the progress lines, one line each, while the command works."""
        lines = []
        vdbscatter.bake(CLOUD, self.path("lit.vdb"), sun=(0, -1, 0), quality="medium",
                        progress=lines.append)
        self.assertGreater(len(lines), 0)
        for line in lines:
            self.assertNotIn("\r", line)
            self.assertNotIn("\n", line)

    def test_docstrings_hold_the_help(self):
        for command in COMMANDS:
            with self.subTest(command=command):
                function = getattr(vdbscatter, command.replace("-", "_"))
                self.assertIn(cli(command, "--help").stdout, function.__doc__)
        line, = [l for l in cli("bake", "--help").stdout.splitlines() if "--density-scale" in l]
        self.assertIn(line, vdbscatter.bake.__doc__)


class Errors(Base):
    def assert_input_error(self, call, message):
        with self.assertRaises(vdbscatter.InputError) as caught:
            call()
        e = caught.exception
        self.assertEqual((e.message, e.status, e.exit_status), (message, 2, 2))
        self.assertEqual(str(e), message)
        self.assertEqual(os.listdir(self.dir), [])
        return e

    def test_missing_file(self):
        missing, out = self.path("missing.vdb"), self.path("out.vdb")
        for command, call, words in [
                ("bake", lambda: vdbscatter.bake(missing, out, sun=(0, -1, 0)),
                 ["bake", missing, "-o", out, "--sun", "0,-1,0"]),
                ("render", lambda: vdbscatter.render(missing, size=(8, 8)),
                 ["render", missing, "-o", self.path("x.exr"), "--size", "8x8"]),
                ("info", lambda: vdbscatter.info(missing), ["info", missing]),
                ("tradeoff",
                 lambda: vdbscatter.tradeoff(missing, self.path("t"), sun=(0, -1, 0)),
                 ["tradeoff", missing, "-o", self.path("t"), "--sun", "0,-1,0"]),
                ("read_lit", lambda: vdbscatter.read_lit(missing), ["info", missing])]:
            with self.subTest(command=command):
                e = self.assert_input_error(call, cli_error(*words))
                self.assertIn(missing, e.message)

    def test_bad_flag_value(self):
        out = self.path("out.vdb")
        e = self.assert_input_error(
            lambda: vdbscatter.bake(CLOUD, out, sun=(0, -1, 0), albedo="x"),
            cli_error("bake", CLOUD, "-o", out, "--sun", "0,-1,0", "--albedo", "x"))
        self.assertIn("--albedo", e.message)
        self.assert_input_error(
            lambda: vdbscatter.phase_svd(g=2, directions=16),
            cli_error("phase-svd", "--g", "2", "--directions", "16"))

    def test_unknown_keyword(self):
        out = self.path("out.vdb")
        self.assert_input_error(lambda: vdbscatter.bake(CLOUD, out, sun=(0, -1, 0), albdo=0.5),
                                "unknown option 'albdo' for bake (did you mean 'albedo'?)")
        self.assert_input_error(lambda: vdbscatter.phase_svd(g=0, directions=8, zzz=1),
                                "unknown option 'zzz' for phase_svd "
                                "(see help(vdbscatter.phase_svd))")

    def test_values_the_flags_cannot_take(self):
        out = self.path("out.vdb")
        for keywords, flag in [(dict(camera=[(0, 0, 5), (0, 0, 0), 35]), "--camera"),
                               (dict(half="yes"), "--half"),
                               (dict(albedo=True), "--albedo"),
                               (dict(albedo=(0.5, [1, 2])), "--albedo"),
                               (dict(albedo=()), "--albedo")]:
            with self.subTest(keywords=keywords):
                with self.assertRaises(vdbscatter.InputError) as caught:
                    vdbscatter.bake(CLOUD, out, sun=(0, -1, 0), **keywords)
                self.assertTrue(caught.exception.message.startswith(flag),
                                caught.exception.message)
                self.assertEqual(os.listdir(self.dir), [])

    def test_failure_while_working(self):
        """A bake that cannot write its file (RLIMIT_FSIZE): Error, not InputError, with the
        CLI's message and exit status 1."""
        out = self.path("out.vdb")

        def limit():
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))

        # --progress none: the CLI's stderr, not a terminal, would also log each stage done
        p = cli("bake", CLOUD, "-o", out, "--sun", "0,-1,0", "--progress", "none", check=1,
                preexec_fn=limit)
        script = ("import json, sys, vdbscatter\n"
                  "try:\n"
                  "    vdbscatter.bake(sys.argv[1], sys.argv[2], sun=(0, -1, 0))\n"
                  "except vdbscatter.Error as e:\n"
                  "    print(json.dumps([type(e).__name__, e.message, e.status, e.exit_status]))\n")
        run = subprocess.run([sys.executable, "-c", script, CLOUD, out], capture_output=True,
                             text=True, timeout=120, env=python_env(), preexec_fn=limit)
        kind, message, status, exit_status = json.loads(run.stdout)
        self.assertEqual(kind, "Error")
        # The message names the temporary file, .out.vdb.tmp.PID.
        pid = re.compile(r"\.tmp\.\d+")
        self.assertEqual(pid.sub(".tmp.PID", f"vdbscatter bake: {message}"),
                         pid.sub(".tmp.PID", p.stderr.strip()))
        self.assertEqual(exit_status, p.returncode)
        self.assertNotIn(status, (0, 2))
        self.assertEqual(os.listdir(self.dir), [])


class Cancel(Base):
    SCRIPT = """
import sys, vdbscatter
def progress(line):
    if not progress.told:
        progress.told = True
        print("started", flush=True)
progress.told = False
try:
    vdbscatter.bake(sys.argv[1], sys.argv[2], env=(0.3, 0.3, 0.3), quality="ultra",
                    density_scale=20, progress=progress)
except KeyboardInterrupt:
    sys.exit(130)
print("finished", flush=True)
"""

    def test_ctrl_c_leaves_no_file(self):
        """SIGINT while bake works: KeyboardInterrupt in the script, no output and no
        temporary file in the folder."""
        out = self.path("lit.vdb")
        p = subprocess.Popen([sys.executable, "-c", self.SCRIPT, BIG, out],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=python_env())
        self.assertEqual(p.stdout.readline(), "started\n")
        p.send_signal(signal.SIGINT)
        stdout, stderr = p.communicate(timeout=120)
        self.assertEqual(p.returncode, 130, stdout + stderr)
        self.assertEqual(os.listdir(self.dir), [])

    def test_python_m_ctrl_c(self):
        """python3 -m vdbscatter bake with stderr a terminal: progress lines, and SIGINT
        after the first: exit 130, the CLI's message, no file."""
        out = self.path("lit.vdb")
        master, slave = pty.openpty()
        p = subprocess.Popen([sys.executable, "-m", "vdbscatter", "bake", BIG, "-o", out,
                              "--env", "0.3,0.3,0.3", "--quality", "ultra"],
                             stdout=subprocess.PIPE, stderr=slave, env=python_env())
        os.close(slave)
        seen = b""
        try:
            while b"\r" not in seen:
                ready, _, _ = select.select([master], [], [], 60)
                self.assertTrue(ready, f"no progress line after 60 s: {seen!r}")
                seen += os.read(master, 4096)
            p.send_signal(signal.SIGINT)
            while True:
                try:
                    chunk = os.read(master, 4096)
                except OSError:  # EIO: the process closed the terminal
                    break
                if not chunk:
                    break
                seen += chunk
        finally:
            os.close(master)
        stdout, _ = p.communicate(timeout=120)
        self.assertEqual(p.returncode, 130, seen)
        self.assertEqual(stdout, b"")
        self.assertTrue(seen.endswith(b"vdbscatter bake: interrupted\r\n"), seen)
        self.assertEqual(os.listdir(self.dir), [])

    def test_keyboard_interrupt_waits_for_the_command(self):
        """KeyboardInterrupt in the calling thread (Ctrl-C) while bake works: the call
        raises it only once the command has stopped (its worker thread is gone) and left no
        file."""
        timers = []

        def progress(line):
            if not timers:
                timers.append(threading.Timer(0.2, _thread.interrupt_main))
                timers[0].start()

        start = time.monotonic()
        with self.assertRaises(KeyboardInterrupt):
            vdbscatter.bake(BIG, self.path("lit.vdb"), env=(0.3, 0.3, 0.3), quality="ultra",
                            progress=progress)
        self.assertLess(time.monotonic() - start, 5)
        self.assertEqual([t.name for t in threading.enumerate() if t.name.startswith("vdbscatter")],
                         [])
        self.assertEqual(os.listdir(self.dir), [])

    def test_progress_exception_cancels(self):
        """An exception from the progress callable stops the bake and comes out of bake."""
        class Stop(Exception):
            pass

        def progress(line):
            raise Stop(line)

        start = time.monotonic()
        with self.assertRaises(Stop):
            vdbscatter.bake(BIG, self.path("lit.vdb"), env=(0.3, 0.3, 0.3), quality="ultra",
                            progress=progress)
        self.assertLess(time.monotonic() - start, 5)
        self.assertEqual(os.listdir(self.dir), [])


class Module(Base):
    def assert_same_run(self, args, cwd=None):
        theirs = cli(*args, check=None, cwd=cwd)
        ours = python_m(*args, cwd=cwd)
        self.assertEqual((ours.returncode, ours.stdout, ours.stderr),
                         (theirs.returncode, theirs.stdout, theirs.stderr), args)
        return ours

    def test_help_and_usage(self):
        self.assertEqual(self.assert_same_run(["--help"]).returncode, 0)
        self.assertEqual(self.assert_same_run([]).returncode, 2)
        self.assertEqual(self.assert_same_run(["frobnicate"]).returncode, 2)
        self.assert_same_run(["--version"])
        for command in COMMANDS:
            self.assert_same_run([command, "--help"])
        # The usage's command list is the library's.
        usage = python_m("--help").stdout
        listed = re.findall(r"^  (\S+) ", usage.split("commands:\n")[1], re.M)
        self.assertEqual(listed, vdbscatter._COMMANDS)

    def test_bake_as_the_cli(self):
        """The same exit status, output and files."""
        ours, theirs = self.path("py.vdb"), self.path("cli.vdb")
        flags = ["--sun", "0,-1,0", "--json", "-q"]
        p = python_m("bake", CLOUD, "-o", ours, *flags)
        q = cli("bake", CLOUD, "-o", theirs, *flags)
        self.assertEqual((p.returncode, p.stderr), (q.returncode, q.stderr))
        a, b = json.loads(p.stdout), json.loads(q.stdout)
        self.assertEqual((a.pop("output"), b.pop("output")), (ours, theirs))
        self.assert_same_report(b, a, "python3 -m vdbscatter bake --json")
        a, b = vdbscatter.info(ours), vdbscatter.info(theirs)
        a.pop("file"), b.pop("file")
        self.assertEqual(a, b)
        for args in (["bake", self.path("missing.vdb"), "-o", self.path("x.vdb")],
                     ["bake", CLOUD, "-o", self.path("x.vdb"), "--albdo", "0.5"],
                     ["info", "--json", LIT]):
            self.assert_same_run(args)
        self.assertEqual(sorted(os.listdir(self.dir)), ["cli.vdb", "py.vdb"])


class ReadLit(Base):
    def test_grids_against_info(self):
        grids = vdbscatter.read_lit(LIT)
        listed = cli_json("info", LIT)["grids"]
        self.assertEqual(list(grids), [g["name"] for g in listed])
        for g in listed:
            with self.subTest(grid=g["name"]):
                grid = grids[g["name"]]
                self.assertEqual(grid.name, g["name"])
                size = [hi - lo + 1 for lo, hi in zip(g["bbox_min"], g["bbox_max"])]
                channels = (3,) if g["type"].startswith("vec3") else ()
                self.assertEqual(grid.values.shape, tuple(reversed(size)) + channels)
                self.assertEqual(grid.values.dtype, np.float32)
                self.assertEqual(grid.origin, tuple(g["bbox_min"]))
                m = grid.index_to_world
                self.assertEqual(m.shape, (4, 4))
                np.testing.assert_array_equal(m[3], [0, 0, 0, 1])
                # A light's grid is rotated: the voxel size is the length of each axis.
                np.testing.assert_allclose(np.linalg.norm(m[:3, :3], axis=0), g["voxel_size"],
                                           rtol=1e-12)
                # info's world box bounds the voxels' faces, half a voxel beyond the centres.
                lo, hi = np.subtract(g["bbox_min"], 0.5), np.add(g["bbox_max"], 0.5)
                corners = np.array([[(lo, hi)[bit >> a & 1][a] for a in range(3)] + [1]
                                    for bit in range(8)]) @ m.T
                np.testing.assert_allclose(corners[:, :3].min(axis=0), g["world_min"],
                                           rtol=0, atol=1e-9)
                np.testing.assert_allclose(corners[:, :3].max(axis=0), g["world_max"],
                                           rtol=0, atol=1e-9)
                if g["type"] == "float" and g["value_max"] > 0:
                    active = grid.values[grid.values != g["background"]]
                    self.assertEqual(float(grid.values.max()), g["value_max"])
                    if g["name"] == "density":  # every active density is positive
                        self.assertEqual(active.size, g["active_voxels"])
                        self.assertEqual(float(active.min()), g["value_min"])

    def test_values_against_pyopenvdb(self):
        try:
            import pyopenvdb
        except ImportError:
            self.skipTest("no pyopenvdb")
        grids = vdbscatter.read_lit(LIT)
        for name in ("density", "radiance"):
            with self.subTest(grid=name):
                grid = grids[name]
                theirs = pyopenvdb.read(LIT, name)
                dense = np.zeros(grid.values.shape[2::-1] + grid.values.shape[3:], np.float32)
                theirs.copyToArray(dense, ijk=grid.origin)
                # pyopenvdb's arrays are [x][y][z].
                zyx = dense.transpose(2, 1, 0, *range(3, dense.ndim))
                assert_bits_equal(self, grid.values, zyx, name)

    def test_memory_limit(self):
        grids = vdbscatter.read_lit(LIT)
        total = sum(g.values.nbytes for g in grids.values())
        largest = max(grids.values(), key=lambda g: g.values.nbytes)
        # The limit holds all copies together: the largest alone fits, all of them do not.
        with self.assertRaises(vdbscatter.InputError) as caught:
            vdbscatter.read_lit(LIT, max_memory=total - 1)
        message = caught.exception.message
        self.assertIn("max_memory", message)
        self.assertIn(f"{len(grids)} grids", message)
        self.assertIn(f"'{largest.name}'", message)
        self.assertEqual(len(vdbscatter.read_lit(LIT, max_memory=total)), len(grids))


class Lookup(Base):
    """Finding the library without VDBSCATTER_LIBRARY: the installed layout around the
    package, as `cmake --install` lays it out."""

    def import_from(self, site, environ=None):
        env = {k: v for k, v in os.environ.items() if k != "VDBSCATTER_LIBRARY"}
        env.update(environ or {})
        env["PYTHONPATH"] = site
        return subprocess.run([sys.executable, "-c",
                               "import vdbscatter; print(vdbscatter._LIB.path)"],
                              capture_output=True, text=True, timeout=60, env=env)

    def install(self, prefix, libdir):
        site = os.path.join(prefix, "lib", "python3", "dist-packages")
        shutil.copytree(os.path.join(PYTHONPATH, "vdbscatter"), os.path.join(site, "vdbscatter"),
                        ignore=shutil.ignore_patterns("__pycache__"))
        if libdir:
            os.makedirs(os.path.join(prefix, libdir), exist_ok=True)
            os.symlink(os.path.realpath(LIBRARY),
                       os.path.join(prefix, libdir, "libvdbscatter.so.0"))
        return site

    def test_installed_layouts(self):
        multiarch = sysconfig.get_config_var("MULTIARCH")
        for libdir in ["lib"] + ([os.path.join("lib", multiarch)] if multiarch else []):
            with self.subTest(libdir=libdir):
                prefix = self.path(libdir.replace("/", "_"))
                site = self.install(prefix, libdir)
                p = self.import_from(site)
                self.assertEqual(p.stdout.strip(),
                                 os.path.join(prefix, libdir, "libvdbscatter.so.0"),
                                 p.stderr)

    def test_not_found(self):
        # Outside the build tree, whose libvdbscatter.so.0 the walk up would find.
        with tempfile.TemporaryDirectory() as prefix:
            site = self.install(prefix, None)
            p = self.import_from(site, {"VDBSCATTER_LIBRARY": self.path("nowhere.so")})
            self.assertIn("ImportError: vdbscatter: VDBSCATTER_LIBRARY names", p.stderr)
            if ctypes.util.find_library("vdbscatter"):
                self.skipTest("a libvdbscatter is installed on the system")
            p = self.import_from(site)
            self.assertIn("ImportError: vdbscatter: cannot find libvdbscatter.so.0", p.stderr)


class Sequences(Base):
    def test_bake_and_render_a_sequence(self):
        """bake and render take the CLI's frame options: a pattern and frames=, fps=; bake
        returns the sequence summary with each frame's report, a second bake (from Python or
        the CLI: the same hash) skips every frame, render writes each frame's picture, a
        missing frame is an InputError and a corrupt one a partial sequence (exit 3)."""
        for f in (1, 2, 3):
            vdbscatter.sample("smoke", self.path(f"s.{f:04d}.vdb"), res=16, time=(f - 1) / 2)
        words = dict(sun=(0, -1, 0), albedo=0.9, density_scale=8)
        s = vdbscatter.bake(self.path("s.####.vdb"), self.path("lit.$F4.vdb"), frames="1-3",
                            fps=24, **words)
        self.assertEqual((s["frames_total"], s["done"], s["worked"], s["fps"]), (3, 3, 3, 24))
        self.assertEqual([(f["frame"], f["status"], f["report"]["frame"]) for f in s["frames"]],
                         [(1, "baked", 1), (2, "baked", 2), (3, "baked", 3)])
        again = vdbscatter.bake(self.path("s.####.vdb"), self.path("lit.$F4.vdb"),
                                frames="1-3", fps=24, **words)
        self.assertEqual((again["worked"], again["skipped"]), (0, 3))
        cli_s = cli_json("bake", "s.####.vdb", "-o", "lit.$F4.vdb", "--frames", "1-3", "--fps",
                         "24", "--sun", "0,-1,0", "--albedo", "0.9", "--density-scale", "8",
                         cwd=self.dir)
        self.assertEqual((cli_s["worked"], cli_s["skipped"]), (0, 3))
        r = vdbscatter.render(self.path("lit.####.vdb"), self.path("img.####.png"),
                              frames="1-3x2", size=(16, 12))
        self.assertEqual([(f["frame"], f["status"]) for f in r["frames"]],
                         [(1, "rendered"), (3, "rendered")])
        for f in (1, 3):
            self.assertTrue(os.path.getsize(self.path(f"img.{f:04d}.png")) > 0)
        with self.assertRaises(vdbscatter.InputError) as e:
            vdbscatter.bake(self.path("s.####.vdb"), self.path("lit.####.vdb"), frames="1-4",
                            **words)
        self.assertIn("missing: 4", str(e.exception))
        with open(self.path("s.0002.vdb"), "r+b") as f:
            f.truncate(100)
        with self.assertRaises(vdbscatter.Error) as e:
            vdbscatter.bake(self.path("s.####.vdb"), self.path("lit.####.vdb"), force=True,
                            **words)
        self.assertEqual(e.exception.exit_status, 3)


if __name__ == "__main__":
    unittest.main(verbosity=2)
