"""What the sequence tests share (test_sequence_cli, test_sequence_input_cli): running the
CLI, reading a lit VDB's grids densely, and a class that writes a shot of `sample smoke --time`
frames once and bakes sequences of it."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy as np
import pyopenvdb as vdb

EXE = os.environ["VDBSCATTER"]
SCENE = ["--method", "svd", "--quality", "low", "--sun", "0.3,-1,0.2:3,3,3", "--env",
         "0.2,0.3,0.5", "--albedo", "0.99", "--g", "0.5", "--density-scale", "30"]
# The metadata that differs between two bakes of the same frame: the solve's timing.
VARYING = {"vdbscatter_solve_seconds"}


def run(*args, check=0, **kw):
    kw.setdefault("stdout", subprocess.PIPE)
    kw.setdefault("stderr", subprocess.PIPE)
    p = subprocess.run([EXE, *map(str, args)], text=True, timeout=900, **kw)
    if check is not None and p.returncode != check:
        raise AssertionError(f"{args}: exit {p.returncode} (expected {check}): {p.stderr}")
    return p


def grids(path):
    """{name: (active count, bbox, dense values)} of every grid, and the file's metadata."""
    all_grids, meta = vdb.readAll(path)
    out = {}
    for g in all_grids:
        lo, hi = g.evalActiveVoxelBoundingBox()
        shape = tuple(b - a + 1 for a, b in zip(lo, hi))
        if g.valueTypeName == "vec3s":
            shape = shape + (3,)
        values = np.zeros(shape, dtype=np.float32)
        g.copyToArray(values, ijk=lo)
        out[g.name] = (g.activeVoxelCount(), (tuple(lo), tuple(hi)), values)
    return out, dict(meta)


def ms_rms(a, b):
    """The RMS of the difference of the ms grids of two lit VDBs of one frame, relative to
    the RMS of b's."""
    ga, _ = grids(a)
    gb, _ = grids(b)
    va, vb = ga["ms"][2], gb["ms"][2]
    assert va.shape == vb.shape
    return float(np.sqrt(np.mean((va - vb) ** 2)) / np.sqrt(np.mean(vb ** 2)))


class Shot(unittest.TestCase):
    """FRAMES frames of the rising plume at RES^3 as smoke.####.vdb in a temporary folder."""
    FRAMES = 6
    RES = 32

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="vdbscatter-seq-", dir=os.environ.get("VDBSCATTER_TMP"))
        cls.input = os.path.join(cls.tmp, "smoke.####.vdb")
        for f in range(1, cls.FRAMES + 1):
            run("sample", "smoke", "--res", cls.RES, "--time", (f - 1) / (cls.FRAMES - 1), "-o",
                os.path.join(cls.tmp, f"smoke.{f:04d}.vdb"))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    @classmethod
    def out(cls, folder, pattern="lit.####.vdb"):
        return os.path.join(cls.tmp, folder, pattern)

    @classmethod
    def bake_sequence(cls, folder, *extra, check=0):
        """Bakes the shot into folder/lit.####.vdb; returns its summary."""
        os.makedirs(os.path.join(cls.tmp, folder), exist_ok=True)
        summary = os.path.join(cls.tmp, folder, "summary.json")
        run("bake", cls.input, "-o", cls.out(folder), *SCENE, *extra, "--summary", summary,
            "-q", check=check)
        with open(summary) as f:
            return json.load(f)
