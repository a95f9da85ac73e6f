#!/usr/bin/python3
"""Determinism (docs/robustness.md#determinism): a bake's grids are bit-identical whatever
OMP_NUM_THREADS (1, 2, 8) for every method, on the C path; so are the reference's images for
one seed and spp, the ray-marched renders (from the density and from a lit VDB), and the
procedural samples; and four different bakes run at once on the machine's cores give the
same grids, and the same metadata apart from the solve time, as each run alone. Grids are
compared by a digest of every active value (tiles and voxels, with their coordinates) per
grid, not by file bytes: OpenVDB writes a fresh UUID into every file.

The grid digest, the image comparison and the metadata comparison are each shown to tell
apart what must differ (another albedo, another seed, another bake), so that none can pass
by being blind. tests/test_determinism_sweep_cli.py (label long) runs the bigger sweep."""
import hashlib
import os
import shutil
import struct
import subprocess
import tempfile
import unittest

import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]

METHODS = ("single", "pop", "fld", "svd", "inet")
THREADS = (1, 2, 8)
# The metadata that differs between two runs of the same bake: the one timing.
VARYING = {"vdbscatter_solve_seconds"}


def sample(name):
    return os.path.join(SAMPLES, name)


def run(*args, threads=None, check=0):
    env = dict(os.environ)
    if threads is not None:
        env["OMP_NUM_THREADS"] = str(threads)
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True, timeout=900,
                       env=env)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode} (expected {check}): {p.stderr}")
    return p


def pack_value(value):
    """The value's float32 bits (grids here are float or Vec3f; pyopenvdb hands them over as
    Python floats, which hold a float exactly)."""
    if isinstance(value, (tuple, list)):
        return struct.pack(f"<{len(value)}f", *value)
    if isinstance(value, bool):
        return struct.pack("<?", value)
    if isinstance(value, int):
        return struct.pack("<q", value)
    return struct.pack("<f", value)


def grid_digests(path):
    """{grid name: sha256 of its type, transform and every active value with its
    coordinates, in the tree's order}."""
    digests = {}
    for g in vdb.readAll(path)[0]:
        h = hashlib.sha256()
        h.update(g.valueTypeName.encode())
        h.update(repr(g.transform.info()).encode())
        h.update(pack_value(g.background))
        for v in g.citerOnValues():
            h.update(struct.pack("<6i", *v.min, *v.max))
            h.update(pack_value(v.value))
        digests[g.name] = h.hexdigest()
    return digests


def metadata(path):
    """The file's and every grid's metadata without the VARYING keys (which must be there)."""
    grids, file_meta = vdb.readAll(path)
    out = {"file": dict(file_meta)}
    for g in grids:
        out[g.name] = dict(g.metadata)
    for meta in out.values():
        for key in VARYING & set(meta):
            del meta[key]
    return out


def varying_present(path):
    _, file_meta = vdb.readAll(path)
    return VARYING <= set(file_meta) | {k for g in vdb.readAll(path)[0] for k in g.metadata}


class DeterminismCase(unittest.TestCase):
    """The helpers (also tests/test_determinism_sweep_cli.py's)."""

    def setUp(self):
        root = os.environ.get("VDBSCATTER_TMP")
        if root:
            os.makedirs(root, exist_ok=True)
        self.tmp = tempfile.mkdtemp(prefix="determinism_", dir=root)

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.tmp, name)

    def assert_same_grids(self, runs, what):
        """runs: {label: lit VDB}; every grid's digest equal to the first run's."""
        labels = list(runs)
        first = grid_digests(runs[labels[0]])
        self.assertIn("radiance", first, what)
        for label in labels[1:]:
            other = grid_digests(runs[label])
            self.assertEqual(sorted(other), sorted(first), f"{what}: grids of {label}")
            for name in first:
                self.assertEqual(other[name], first[name],
                                 f"{what}: grid {name} of {label} differs from {labels[0]}")

    def bake_threads(self, src, tag, args, threads=THREADS):
        runs = {}
        for t in threads:
            out = self.path(f"{tag}_t{t}.vdb")
            run("bake", src, "-o", out, "--backend", "cpu", "-q", *args, threads=t)
            runs[f"OMP_NUM_THREADS={t}"] = out
        return runs


class Determinism(DeterminismCase):
    def test_methods_across_thread_counts(self):
        """Every method's bake of the sphere (sun and sky at low quality) at 1, 2 and 8 threads."""
        base = ["--sun", "0.3,-1,0.2", "--env", "0.2,0.25,0.3", "--density-scale", "6",
                "--albedo", "0.9", "--g", "0.5", "--quality", "low"]
        for method in METHODS:
            with self.subTest(method=method):
                runs = self.bake_threads(sample("sphere.vdb"), method, base + ["--method", method])
                self.assert_same_grids(runs, method)
        # The digest sees a change in the values: another albedo, another radiance.
        other = self.path("other.vdb")
        run("bake", sample("sphere.vdb"), "-o", other, "--backend", "cpu", "-q", *base,
            "--albedo", "0.8", "--method", "svd", threads=2)
        self.assertNotEqual(grid_digests(other)["radiance"],
                            grid_digests(self.path("svd_t2.vdb"))["radiance"])

    def test_point_light_and_scene_across_thread_counts(self):
        """POP's radial grid and the point light's sweeps (the sphere's scene: sun and point)."""
        for method in ("pop", "svd"):
            with self.subTest(method=method):
                runs = self.bake_threads(sample("sphere.vdb"), f"scene_{method}",
                                         ["--scene", sample("sphere.json"), "--method", method],
                                         threads=(1, 8))
                self.assert_same_grids(runs, f"sphere.json {method}")

    def test_reference_render_across_thread_counts(self):
        """--mode reference: one seed and spp, the same image (every pixel's bits: the EXR file
        holds nothing else that varies) at 1, 2 and 8 threads; another seed, another image."""
        images = {}
        args = ["render", sample("cube.vdb"), "--mode", "reference", "--sun", "0,-1,0.3",
                "--env", "0.1,0.1,0.1", "--density-scale", "4", "--albedo", "0.9",
                "--size", "24x18", "--spp", "4", "--max-bounces", "16", "-q"]
        for t in THREADS:
            out = self.path(f"ref_t{t}.exr")
            run(*args, "--seed", "7", "-o", out, threads=t)
            with open(out, "rb") as f:
                images[t] = f.read()
        for t in THREADS[1:]:
            self.assertEqual(images[t], images[1], f"reference image at {t} threads")
        out = self.path("ref_seed8.exr")
        run(*args, "--seed", "8", "-o", out, threads=2)
        with open(out, "rb") as f:
            self.assertNotEqual(f.read(), images[1])

    def test_march_render_across_thread_counts(self):
        """--mode single (the ray march with light marches) and --mode baked (a lit VDB): the
        same image at 1 and 8 threads."""
        lit = self.path("lit.vdb")
        run("bake", sample("sphere.vdb"), "--scene", sample("sphere.json"), "--method", "fld",
            "--backend", "cpu", "-o", lit, "-q")
        for mode, src in (("single", sample("sphere.vdb")), ("baked", lit)):
            with self.subTest(mode=mode):
                images = {}
                for t in (1, 8):
                    out = self.path(f"{mode}_t{t}.exr")
                    extra = ["--scene", sample("sphere.json")] if mode == "single" else []
                    run("render", src, *extra, "--mode", mode, "--backend", "cpu", "--size",
                        "48x36", "-q", "-o", out, threads=t)
                    with open(out, "rb") as f:
                        images[t] = f.read()
                self.assertEqual(images[8], images[1], mode)

    def test_samples_across_thread_counts(self):
        """`vdbscatter sample`: the procedural volumes do not depend on the threads."""
        for name in ("cloud", "smoke"):
            with self.subTest(name=name):
                runs = {}
                for t in (1, 8):
                    out = self.path(f"{name}_t{t}.vdb")
                    run("sample", name, "-o", out, threads=t)
                    runs[t] = grid_digests(out)
                self.assertEqual(runs[8], runs[1], name)
                self.assertTrue(runs[1])

    def test_concurrent_bakes_match_alone(self):
        """Four bakes of different volumes started at once (more threads than cores: each
        takes OpenMP's default) give the grids, and the metadata apart from the solve time,
        of the same bakes run one at a time."""
        jobs = {
            "cube": [sample("cube.vdb"), "--sun", "0,-1,0", "--density-scale", "4",
                     "--method", "fld"],
            "sphere": [sample("sphere.vdb"), "--scene", sample("sphere.json"), "--method", "pop"],
            "slab": [sample("slab.vdb"), "--scene", sample("slab.json"), "--method", "svd"],
            "smoke": [sample("smoke.vdb"), "--scene", sample("smoke.json"), "--method", "single"],
        }
        common = ["--backend", "cpu", "--quality", "low", "-q"]
        for name, args in jobs.items():
            run("bake", *args, "-o", self.path(f"{name}_alone.vdb"), *common)
        procs = {name: subprocess.Popen([EXE, "bake", *args, "-o", self.path(f"{name}_load.vdb"),
                                         *common], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE, text=True)
                 for name, args in jobs.items()}
        for name, p in procs.items():
            _, err = p.communicate(timeout=900)
            self.assertEqual(p.returncode, 0, f"{name}: {err}")
        for name in jobs:
            alone, load = self.path(f"{name}_alone.vdb"), self.path(f"{name}_load.vdb")
            self.assert_same_grids({"alone": alone, "under load": load}, name)
            self.assertTrue(varying_present(alone), f"{name}: no {VARYING} in the metadata")
            self.assertEqual(metadata(load), metadata(alone), f"{name}: metadata")
        # The metadata comparison sees a difference: another method, other metadata.
        self.assertNotEqual(metadata(self.path("cube_alone.vdb")),
                            metadata(self.path("sphere_alone.vdb")))


if __name__ == "__main__":
    unittest.main()
