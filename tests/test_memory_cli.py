#!/usr/bin/python3
"""Bounded memory (--max-memory; docs/robustness.md "Bounded memory") through the command:
a SIZE that is not one is one line and exit 2 on bake, render and tradeoff; an input whose
estimate exceeds the limit is refused before the large allocations (two blobs 1.7 km apart,
whose light grids span the whole box between them, at 1 m voxels under a given limit and at
1 mm under the default one, and a dense fog rendered at medium), with
the need, the limit and the flags that lower it on one line, exit 2 and no output; a limit
that fits bakes the very grids no limit does; the --json report (and --report) carries the
limit, the estimate by part and each stage's peak resident set; and the estimate holds
against the measured growth of the peak over the resident set it starts from, on a bake and
a render of a fog (within 0.7x-1.5x: below 0.7 the limit would let an input through that
needs far more than it says, above 1.5 it would refuse ones that fit; the estimate counts
the large arrays only, and the allocator's and OpenVDB's small ones go uncounted); with
--keep-state the estimate counts the state grids the lit VDB then holds, for every method
that keeps state, and holds against the growth of an SVD bake that keeps them; the solvers'
own per-voxel arrays are counted and the estimate holds for SVD, FLD and INET bakes too.
Set VDBSCATTER_MEMORY_VERBOSE=1 to print the measured numbers."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy as np
import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
VERBOSE = os.environ.get("VDBSCATTER_MEMORY_VERBOSE") == "1"
GIB = 1 << 30


def run(*args, check=None):
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=600)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode}, stderr: {p.stderr}")
    return p


def write_vdb(path, grid, voxel):
    grid.name = "density"
    grid.gridClass = vdb.GridClass.FOG_VOLUME
    grid.transform = vdb.createLinearTransform(voxelSize=voxel)
    vdb.write(path, grids=[grid])


def sanitized():
    """Whether the binary runs under AddressSanitizer (scripts/test.sh's second pass): its
    allocator keeps freed memory resident and shadows the rest, so resident sets say nothing
    of the estimate there, and the bakes take many times longer."""
    p = subprocess.run(["ldd", EXE], capture_output=True, text=True)
    return "libasan" in p.stdout


def default_limit():
    """75% of MemTotal or of the cgroup's limit where lower (memory.h)."""
    with open("/proc/meminfo") as f:
        total = next(int(l.split()[1]) * 1024 for l in f if l.startswith("MemTotal:"))
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < total:
            total = int(text)
    return int(total * 0.75)


class MemoryCliTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        root = os.environ.get("VDBSCATTER_TMP") or tempfile.gettempdir()
        os.makedirs(root, exist_ok=True)
        cls.dir = tempfile.mkdtemp(prefix="vdbscatter-memory-", dir=root)
        # Two 8^3 blobs of 1 m voxels, 1000 voxels apart along each axis (1.7 km): 1024
        # active voxels, a support box of 1008^3.
        blobs = vdb.FloatGrid()
        block = cls.block = np.ones((8, 8, 8), dtype=np.float32)
        blobs.copyFromArray(block, ijk=(0, 0, 0))
        blobs.copyFromArray(block, ijk=(1000, 1000, 1000))
        cls.blobs = os.path.join(cls.dir, "blobs.vdb")
        write_vdb(cls.blobs, blobs, 1.0)
        # A fog of 100^3 voxels (1 M): large arrays, little solver time with one sun.
        fog = vdb.FloatGrid()
        fog.copyFromArray(np.full((100, 100, 100), 0.5, dtype=np.float32), ijk=(0, 0, 0))
        cls.fog = os.path.join(cls.dir, "fog.vdb")
        write_vdb(cls.fog, fog, 0.01)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_refused(self, args, output, needles):
        """Exit 2, one line on stderr holding every needle, no output (nor temporary) file."""
        p = run(*args)
        self.assertEqual(p.returncode, 2, f"{args}: {p.stderr}")
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, f"{args}: {p.stderr!r}")
        for needle in needles:
            self.assertIn(needle, lines[0], f"{args}")
        self.assertFalse(os.path.exists(output), f"{args} left {output}")
        self.assertEqual([f for f in os.listdir(self.dir) if ".tmp." in f], [])
        return lines[0]

    def test_size_errors(self):
        out_vdb, out_exr, out_dir = self.path("bad.vdb"), self.path("bad.exr"), self.path("bad")
        cloud = os.path.join(SAMPLES, "cloud.vdb")
        commands = {
            "bake": (["bake", cloud, "-o", out_vdb, "--sun", "0,-1,0"], out_vdb),
            "render": (["render", cloud, "-o", out_exr, "--sun", "0,-1,0"], out_exr),
            "tradeoff": (["tradeoff", cloud, "-o", out_dir, "--sun", "0,-1,0"], out_dir),
        }
        for command, (args, out) in commands.items():
            for size in ("12Q", "0", "-1G", "lots", "8 G", ""):
                line = self.assert_refused(args + ["--max-memory", size], out,
                                           [f"vdbscatter {command}: --max-memory: "])
                if size == "12Q":
                    self.assertIn("unknown unit", line)

    def test_blobs_far_apart_refused(self):
        """A kilometre between two blobs: each sky ordinate's light grid has columns over
        the whole box (about 2.6 M at --s1-oversample 1), so the render's 65 grids at medium
        need gigabytes for 1024 voxels."""
        out = self.path("blobs.exr")
        line = self.assert_refused(
            ["render", self.blobs, "-o", out, "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5",
             "--quality", "medium", "--max-memory", "1G"], out,
            ["vdbscatter render: needs ", "light grids", "65 light grids at --quality medium",
             "over the 1.0 GiB limit (--max-memory)", "lower --quality", "--s1-oversample",
             "raise --max-memory"])
        need = float(line.split("needs ")[1].split()[0])
        unit = line.split("needs ")[1].split()[1]
        self.assertEqual(unit, "GiB", line)
        self.assertGreater(need, 1.0)
        # At 1 mm voxels the box is 10^6 voxels across: the grid's own column records would
        # be petabytes, refused at the default limit without planning them.
        far = vdb.FloatGrid()
        far.copyFromArray(self.block, ijk=(0, 0, 0))
        far.copyFromArray(self.block, ijk=(1000000, 1000000, 1000000))
        far_in = self.path("far.vdb")
        write_vdb(far_in, far, 0.001)
        for command, out in (("bake", self.path("far_lit.vdb")), ("render", self.path("far.png"))):
            self.assert_refused([command, far_in, "-o", out, "--sun", "0.3,-1,0.2"], out,
                                       [f"vdbscatter {command}: needs ", " PiB (light grids ",
                                        "limit (default: 75% of this machine's or cgroup's memory)"])
        # The bake builds one grid at a time, but at --s1-oversample 4 one has 42 M columns
        # (about 530 MiB in all).
        lit = self.path("blobs_lit.vdb")
        self.assert_refused(
            ["bake", self.blobs, "-o", lit, "--sun", "0.3,-1,0.2", "--method", "single",
             "--s1-oversample", "4", "--max-memory", "256M", "-q"], lit,
            ["vdbscatter bake: needs ", "light grids", "--s1-oversample 4",
             "over the 256 MiB limit (--max-memory)", "lower --quality, --s1-oversample"])

    def test_fog_render_refused(self):
        out = self.path("fog.png")
        self.assert_refused(
            ["render", self.fog, "-o", out, "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5",
             "--density-scale", "50", "--quality", "medium", "--max-memory", "300M"], out,
            ["vdbscatter render: needs ", "light grids", "65 light grids at --quality medium",
             "over the 300 MiB limit (--max-memory)"])

    def test_fitting_limit_bakes_the_same(self):
        if sanitized():
            self.skipTest("the bakes' numbers are the normal pass's to check")
        cloud = os.path.join(SAMPLES, "cloud.json")
        a, b = self.path("limited.vdb"), self.path("unlimited.vdb")
        common = ["--scene", cloud, "--method", "single", "--backend", "cpu", "-q"]
        run("bake", *common, "-o", a, "--max-memory", "4GiB", check=0)
        run("bake", *common, "-o", b, "--max-memory", "none", check=0)
        names = [m["name"] for m in vdb.readAllGridMetadata(a)]
        self.assertEqual(names, [m["name"] for m in vdb.readAllGridMetadata(b)])
        self.assertIn("sky_depth_0000", names)
        for name in names:
            ga, gb = vdb.read(a, name), vdb.read(b, name)
            va = sorted((tuple(i.min), i.value) for i in ga.citerOnValues())
            vb = sorted((tuple(i.min), i.value) for i in gb.citerOnValues())
            self.assertEqual(va, vb, name)

    def growth(self, report, stages):
        m = report["memory"]
        peak = max(m["peak_bytes"][s] for s in stages)
        return m["estimate_bytes"], peak - m["baseline_bytes"]

    def assert_holds(self, what, report, stages):
        """The estimate within 0.7-1.5x of the growth of the stages' peak."""
        est, grew = self.growth(report, stages)
        if VERBOSE:
            print(f"\n{what}: estimate {est / 2**20:.1f} MiB {report['memory']['estimate']}, "
                  f"grew {grew / 2**20:.1f} MiB")
        self.assertTrue(0.7 * grew <= est <= 1.5 * grew,
                        f"{what}: estimate {est} against a growth of {grew}")

    def test_report_and_estimate_against_peak(self):
        if sanitized():
            self.skipTest("resident sets under AddressSanitizer are its allocator's")
        lit, rep = self.path("fog_lit.vdb"), self.path("fog_report.json")
        p = run("bake", self.fog, "-o", lit, "--sun", "0.3,-1,0.2", "--density-scale", "50",
                "--method", "single", "--backend", "cpu", "--json", "--report", rep, check=0)
        j = json.loads(p.stdout)
        with open(rep) as f:
            self.assertEqual(json.load(f)["memory"]["estimate"], j["memory"]["estimate"])
        m = j["memory"]
        self.assertEqual(m["limit_bytes"], default_limit())
        self.assertEqual(sorted(m["peak_bytes"]), ["load", "solve", "write"])
        self.assertTrue(m["peak_per_stage"])
        self.assertEqual(sum(m["estimate"].values()), m["estimate_bytes"])
        for part in ("outputs", "stored depths"):
            self.assertGreater(m["estimate"][part], 0)
        # the stages' own peaks: the load's holds the volume, the solve's and the write's
        # what the load left plus their own
        self.assertGreater(m["peak_bytes"]["load"], 0)
        for stage in ("solve", "write"):
            self.assertGreaterEqual(m["peak_bytes"][stage], m["baseline_bytes"] * 0.9)

        img = self.path("fog.exr")
        p = run("render", self.fog, "-o", img, "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5",
                "--density-scale", "50", "--quality", "low", "--backend", "cpu", "--size",
                "320x240", "--json", check=0)
        r = json.loads(p.stdout)
        self.assertEqual(sorted(r["memory"]["peak_bytes"]), ["load", "render", "write"])
        self.assertGreater(r["memory"]["estimate"]["light grids"], 0)
        for what, report, stages in (("bake", j, ["solve", "write"]),
                                     ("render", r, ["render", "write"])):
            self.assertGreater(self.growth(report, stages)[1], 50 << 20, what)  # measurable
            self.assert_holds(what, report, stages)

    def test_solvers_estimate_against_peak(self):
        """The methods that hold arrays of their own per output voxel while they solve (SVD,
        FLD, INET: the voxels' faces and the first collisions' sums and scratch) have them in
        the estimate beside the S1 pass, and each bake's estimate holds against its growth
        within the same 0.7-1.5x. Without them the fog's estimates were 0.71 (SVD), 0.53 (FLD)
        and 0.60 (INET) of the growth."""
        if sanitized():
            self.skipTest("resident sets under AddressSanitizer are its allocator's")
        for method in ("svd", "fld", "inet"):
            r = json.loads(run("bake", self.fog, "-o", self.path(f"{method}.vdb"), "--sun",
                               "0.3,-1,0.2", "--density-scale", "50", "--g", "0.8", "--method",
                               method, "--backend", "cpu", "--store", "none", "--json",
                               check=0).stdout)
            self.assertGreater(r["memory"]["estimate"]["solver"], 0, method)
            self.assert_holds(method, r, ["solve", "write"])

    def test_kept_state_counted(self):
        """--keep-state's grids are in the estimate: SVD keeps one per phase term, 3 floats per
        output voxel while it solves, and writes their trees with the outputs. The estimate
        holds against the growth as the plain bake's does (without them it measured 0.39 of
        it), and a limit between the two bakes' needs lets the plain one through and refuses
        the kept one, naming --keep-state."""
        if sanitized():
            self.skipTest("resident sets under AddressSanitizer are its allocator's")
        args = ["bake", self.fog, "--sun", "0.3,-1,0.2", "--density-scale", "50", "--g", "0.8",
                "--method", "svd", "--svd-terms", "8", "--backend", "cpu", "--store", "none",
                "--json"]
        plain = json.loads(run(*args, "-o", self.path("svd.vdb"), check=0).stdout)
        kept_out = self.path("svd_kept.vdb")
        kept = json.loads(run(*args, "-o", kept_out, "--keep-state", check=0).stdout)
        self.assertNotIn("kept state", plain["memory"]["estimate"])
        self.assertEqual(kept["svd"]["terms"], 8)
        self.assertEqual(kept["memory"]["estimate"]["kept state"],
                         8 * 3 * 4 * kept["output_voxels"])
        # the kept arrays, and their trees in the write on top
        self.assertGreater(kept["memory"]["estimate_bytes"] - plain["memory"]["estimate_bytes"],
                           kept["memory"]["estimate"]["kept state"])
        self.assert_holds("svd --keep-state", kept, ["solve", "write"])
        need = [r["memory"]["estimate_bytes"] + r["memory"]["baseline_bytes"] for r in (plain, kept)]
        limit = str((need[0] + need[1]) // 2)
        run(*args, "-o", self.path("svd_limited.vdb"), "--max-memory", limit, check=0)
        os.remove(kept_out)
        self.assert_refused(args + ["-o", kept_out, "--keep-state", "--max-memory", limit],
                            kept_out, ["vdbscatter bake: needs ", "--keep-state 8 grids",
                                       "over the ", "lower --quality, --s1-oversample, "
                                       "--keep-state or raise --max-memory"])

    def test_inet_network_counted(self):
        """The illumination network's arrays (per particle and direction: its link, emission
        and the sweep's state) are in the estimate: with 150000 particles on the fog the
        network is most of the solve, and the estimate holds against the growth (1.06; without
        it, 253 MiB for a growth of 609). 20 M particles on 64 directions (about 56 GB of
        network) are refused before they are allocated, the advice naming --inet-particles."""
        args = ["bake", self.fog, "--sun", "0.3,-1,0.2", "--density-scale", "50", "--g", "0.8",
                "--method", "inet", "--inet-iterations", "2", "--backend", "cpu", "--store",
                "none"]
        out = self.path("inet_network.vdb")
        self.assert_refused(args + ["-o", out, "--inet-particles", "20000000"], out,
                            ["vdbscatter bake: needs ", "over the ",
                             "lower --quality, --s1-oversample, --inet-particles or raise"])
        if sanitized():
            self.skipTest("resident sets under AddressSanitizer are its allocator's")
        few = json.loads(run(*args, "-o", out, "--json", check=0).stdout)
        many = json.loads(run(*args, "-o", out, "--inet-particles", "150000", "--json",
                              check=0).stdout)
        # the particles' part alone: 145000 more particles, 64 directions, 44 bytes a slot
        grew = many["memory"]["estimate"]["solver"] - few["memory"]["estimate"]["solver"]
        self.assertGreater(grew, 145000 * 64 * 44)
        self.assert_holds("inet, 150000 particles", many, ["solve", "write"])

    def test_kept_state_is_what_is_written(self):
        """Each method that keeps state: the estimate's kept state is 3 floats per output voxel
        for every state grid the lit VDB then holds (SVD at its own terms rule, FLD's fluence,
        INET's directions), and a warm-started SVD bake keeps its warm start's terms."""
        cloud = os.path.join(SAMPLES, "cloud.json")
        prefixes = {"svd": "svd_m", "fld": "fld_phi", "inet": "inet_r"}
        for method, prefix in prefixes.items():
            out = self.path(f"kept_{method}.vdb")
            args = ["bake", "--scene", cloud, "--method", method, "--keep-state", "--json", "-q"]
            runs = [args + ["-o", out]]
            if method == "svd":
                runs.append(args + ["-o", self.path("kept_warm.vdb"), "--warm-start", out])
            for words in runs:
                r = json.loads(run(*words, check=0).stdout)
                written = words[words.index("-o") + 1]
                names = [m["name"] for m in vdb.readAllGridMetadata(written)]
                grids = sum(n.startswith(prefix) for n in names)
                self.assertGreater(grids, 0, method)
                self.assertEqual(r["memory"]["estimate"]["kept state"],
                                 grids * 3 * 4 * r["output_voxels"], words)


if __name__ == "__main__":
    unittest.main()
