#!/usr/bin/python3
"""Seams: does the multiple-scattering field show the solver's coarse cells, and what does
smoothing cost in accuracy? POP, FLD and SVD at --quality low on the cloud sample
(samples/cloud.json) and on the Disney cloud at 1/16 (bench_defaults.py's scene: cloud.json's
sun and sky, albedo 0.99, g 0.85, --density-scale auto:10; skipped without the external data),
each baked by two binaries: --before (a build of the parent commit: trilinear upsampling) and
BUILD (the B-spline). Per bake: the seam ratio of the lit VDB's ms grid on each index axis
(docs/design.md "Upsampling without seams"; the same measure as tests/seams.c, here in numpy)
and the baked image's relative RMSE against a Monte-Carlo reference of the same view (one
reference per volume, --ref-spp samples, seed 11). Writes a Markdown table.

usage: bench/bench_seams.py BUILD_DIR --before OLD_VDBSCATTER [--out bench/seams.md]
       [--size 160x120] [--ref-spp 1024] [--data ../shared/data] [--cache DIR]
Run with OMP_NUM_THREADS=1 on a shared machine (nothing here is timed, but the reference is
long); pyopenvdb needs /usr/bin/python3."""
import argparse
import json
import math
import os
import tempfile

import numpy as np
import pyopenvdb as vdb

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
METHODS = ["pop", "fld", "svd"]
# tests/seams.c's constants: neighbouring frequencies in bins of the shortest run admitted,
# and that run's least length in voxels and in cells.
OFFSETS = [-3.0, -2.0, 2.0, 3.0]
MIN_RUN = 16
MIN_CELLS = 4.0


def scenes(data, tmp):
    cloud = os.path.join(ROOT, "samples", "cloud.json")
    out = [("cloud sample", cloud)]
    wdas = os.path.join(data, "wdas_cloud_sixteenth.vdb")
    if os.path.exists(wdas):
        s = json.load(open(cloud))
        s["volume"] = {"file": wdas, "density_scale": "auto:10", "albedo": 0.99, "g": 0.85}
        s.pop("camera", None)  # the render frames the whole volume
        path = os.path.join(tmp, "wdas.json")
        json.dump(s, open(path, "w"))
        out.append(("Disney cloud 1/16", path))
    return out


def dense(grid, lo, hi):
    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi))
    if isinstance(grid, vdb.FloatGrid):
        arr = np.zeros(shape, dtype=np.float32)
    else:
        arr = np.zeros(shape + (3,), dtype=np.float32)
    grid.copyToArray(arr, ijk=tuple(int(x) for x in lo))
    return arr


def seam_axis(m, inside, a, cell_voxels):
    """tests/seams.c's test_seams_dense on one index axis (the same steps, in numpy)."""
    b, c = (a + 1) % 3, (a + 2) % 3
    mm = np.transpose(m, (c, b, a))
    ins = np.transpose(inside, (c, b, a))
    n = mm.shape[2]
    f0 = 1.0 / cell_voxels
    shortest = max(MIN_CELLS / f0, float(MIN_RUN))
    if f0 < 0.5:
        shortest = max(shortest, math.floor(OFFSETS[-1] / (0.5 - f0)) + 1.0)
    min_run = math.ceil(shortest)
    freqs = np.array([f0] + [f0 + o / min_run for o in OFFSETS])
    if freqs[1] <= 0.0 or freqs[-1] >= 0.5 or n < min_run + 2:
        return 0.0
    ok = ins[..., :-2] & ins[..., 1:-1] & ins[..., 2:]  # d2 of voxel t + 1 at index t
    d2 = mm[..., 2:] - 2.0 * mm[..., 1:-1] + mm[..., :-2]
    power = np.zeros(len(freqs))
    for k in range(mm.shape[0]):
        plane = np.zeros(len(freqs), dtype=complex)  # this plane's lines, summed in phase
        for j in range(mm.shape[1]):
            edges = np.diff(np.concatenate(([0], ok[k, j].astype(np.int8), [0])))
            for s0, e0 in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
                length = e0 - s0
                if length < min_run:
                    continue
                x = np.arange(length, dtype=np.float64)
                y = np.abs(d2[k, j, s0:e0])
                slope, icept = np.polyfit(x, y, 1)
                w = 0.5 - 0.5 * np.cos(2.0 * np.pi * (x + 0.5) / length)
                y = w * (y - icept - slope * x)
                pos = s0 + 1 + x  # absolute voxel positions along the line
                plane += np.exp(-2j * np.pi * np.outer(freqs, pos)) @ y
        power += np.abs(plane) ** 2
    nb = power[1:].mean()
    return power[0] / nb if nb > 0.0 else 0.0


def seam_ratios(lit, density_path, cell_world, grid="ms"):
    """The seam ratio per index axis of a lit VDB's grid (luminance) over the medium (the
    density grid's voxels > 0) for world cells of side cell_world."""
    dens = vdb.read(density_path, "density")
    ms = vdb.read(lit, grid)
    lo, hi = dens.evalActiveVoxelBoundingBox()
    lo = [l - 1 for l in lo]  # the output voxels: the active region dilated by one voxel
    hi = [h + 1 for h in hi]
    d = dense(dens, lo, hi)
    m = dense(ms, lo, hi) @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    m = m.astype(np.float64)
    voxel = dens.transform.voxelSize()
    return [seam_axis(m, d > 0, a, cell_world / voxel[a]) for a in range(3)]


def cell_side(report, extent):
    method = report["method"]
    block = report[method]
    if method == "pop":
        return 0.5 * extent / block["resolution"]  # the merged grid: half a directional cell
    return extent / block["resolution"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--before", required=True, help="vdbscatter built from the parent commit")
    ap.add_argument("--out", default=os.path.join(HERE, "seams.md"))
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "data"))
    ap.add_argument("--cache", default=None, help="keep the references here between runs")
    args = ap.parse_args()
    after = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-seams-")
    cache = args.cache or tmp
    os.makedirs(cache, exist_ok=True)
    view = ["--size", args.size, "--backend", "cpu"]
    lines = [f"`OMP_NUM_THREADS=1 bench/bench_seams.py BUILD --before PARENT/vdbscatter --size "
             f"{args.size} --ref-spp {args.ref_spp}` (C path). Seam ratio of ms per index axis "
             "x / y / z (bar <= 1.5; ms_l1: the worst of its x, y, z grids per axis); error: baked image relative RMSE against the reference "
             "(se_b: its own noise). before: trilinear upsampling (parent commit); after: "
             "the B-splines (POP smoothing, FLD and SVD interpolating); upsample s: the solver's "
             "upsampling stage, before / after.", "",
             "| solver | volume | cell voxels | ms seams before | ms seams after | "
             "ms_l1 seams before | ms_l1 seams after | error before | error after | se_b | "
             "upsample s |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for title, scene in scenes(args.data, tmp):
        ref = os.path.join(cache, f"ref-{os.path.basename(scene)}-{args.size}-{args.ref_spp}.exr")
        if not os.path.exists(ref):
            run_json([after, "render", "--scene", scene, "-o", ref, "--mode", "reference",
                      "--spp", str(args.ref_spp), "--seed", "11", *view, "--json", "-q"])
        s = json.load(open(scene))
        density = os.path.join(os.path.dirname(scene), s["volume"]["file"])
        for method in METHODS:
            row = {}
            for label, exe in (("before", args.before), ("after", after)):
                lit = os.path.join(tmp, "lit.vdb")
                rep = run_json([exe, "bake", "--scene", scene, "-o", lit, "--method", method,
                                "--quality", "low", "--backend", "cpu", "--json", "-q"])
                img = os.path.join(tmp, "img.exr")
                run_json([exe, "render", lit, "-o", img, *view, "--json", "-q"])
                cmp = run_json([after, "compare", img, ref, "--json"])
                dens = vdb.read(density, "density")
                lo, hi = dens.evalActiveVoxelBoundingBox()
                # vdbs_volume_support_extent: the active box grown by a voxel on each side.
                ext = max((h - l + 2) * v
                          for l, h, v in zip(lo, hi, dens.transform.voxelSize()))
                cell = cell_side(rep, ext)
                l1 = [seam_ratios(lit, density, cell, g) for g in ("ms_l1x", "ms_l1y", "ms_l1z")]
                row[label] = (seam_ratios(lit, density, cell), cmp["relrmse"], cmp["se_b"],
                              cell / dens.transform.voxelSize()[0],
                              rep["seconds"].get(f"{method}_upsample", 0.0),
                              [max(r[a] for r in l1) for a in range(3)])
            b, a = row["before"], row["after"]
            fmt = lambda r: " / ".join(f"{x:.2f}" for x in r)
            line = (f"| {method} | {title} | {a[3]:.2f} | {fmt(b[0])} | {fmt(a[0])} | "
                    f"{fmt(b[5])} | {fmt(a[5])} | {b[1]:.4f} | {a[1]:.4f} | {a[2]:.4f} | "
                    f"{b[4]:.2f} / {a[4]:.2f} |")
            lines.append(line)
            print(line, flush=True)
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
