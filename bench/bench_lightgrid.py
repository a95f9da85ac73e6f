#!/usr/bin/python3
"""Single scattering from light grids (bake --s1 grid) against the exact per-voxel march
(--s1 march), side by side in one run, C path: time per doubling of the resolution of the
procedural cloud, and the Disney cloud at density scale 0.2 with a sun and a 64-direction sky
(time and relative RMSE of radiance over voxels above 1e-3 of the maximum).

usage: bench/bench_lightgrid.py BUILD_DIR [--out bench/lightgrid.md]"""
import argparse
import os
import subprocess
import tempfile

import numpy as np

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.join(ROOT, "..", "shared", "data")


def radiance(path):
    import pyopenvdb
    grid = pyopenvdb.read(path, "radiance")
    values = [v.value for v in grid.citerOnValues()]
    return np.array(values, dtype=np.float64).reshape(-1)


def relrmse(a, b):
    mask = b > 1e-3 * b.max()
    return float(np.sqrt(np.sum((a[mask] - b[mask]) ** 2) / np.sum(b[mask] ** 2)))


def bake(exe, src, out, s1, extra):
    rep = run_json([exe, "bake", src, "-o", out, "--backend", "cpu", "--s1", s1, "--json", "-q",
                    *extra])
    return rep["seconds"]["solve"], rep["output_voxels"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "lightgrid.md"))
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-lightgrid-")
    sun = ["--density-scale", "20", "--sun", "0.3,-1,0.2"]
    sky = sun + ["--env", "0.2,0.3,0.5", "--quality", "medium"]
    lines = ["| case | output voxels | march s | grid s | march / grid | grid relative RMSE |",
             "|---|---|---|---|---|---|"]
    scaling = {"march": [], "grid": []}
    for res, light, label, with_march in [(64, sun, "sun", True), (128, sun, "sun", True),
                                          (256, sun, "sun", True), (64, sky, "sun + 64 sky", True),
                                          (128, sky, "sun + 64 sky", False)]:
        src = os.path.join(tmp, f"cloud{res}.vdb")
        if not os.path.exists(src):
            subprocess.run([exe, "sample", "cloud", "--res", str(res), "-o", src], check=True)
        g, voxels = bake(exe, src, os.path.join(tmp, "g.vdb"), "grid", light)
        if with_march:
            m, _ = bake(exe, src, os.path.join(tmp, "m.vdb"), "march", light)
            err = relrmse(radiance(os.path.join(tmp, "g.vdb")), radiance(os.path.join(tmp, "m.vdb")))
            row = f"| cloud {res}^3, {label} | {voxels} | {m:.3f} | {g:.3f} | {m / g:.2f} | {err:.2e} |"
        else:
            m = None
            row = f"| cloud {res}^3, {label} | {voxels} | (not run) | {g:.3f} | | |"
        if label == "sun":
            scaling["grid"].append(g)
            scaling["march"].append(m)
        lines.append(row)
        print(row, flush=True)
    wdas = os.path.join(DATA, "wdas_cloud_sixteenth.vdb")
    extra = ["--density-scale", "0.2", "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5",
             "--quality", "medium"]
    g, voxels = run_json([exe, "bake", wdas, "-o", os.path.join(tmp, "g.vdb"), "--backend", "cpu",
                          "--s1", "grid", "--json", "-q", *extra])["seconds"]["solve"], None
    rep = run_json([exe, "bake", wdas, "-o", os.path.join(tmp, "m.vdb"), "--backend", "cpu",
                    "--s1", "march", "--json", "-q", *extra])
    m, voxels = rep["seconds"]["solve"], rep["output_voxels"]
    err = relrmse(radiance(os.path.join(tmp, "g.vdb")), radiance(os.path.join(tmp, "m.vdb")))
    row = f"| wdas_cloud_sixteenth at 0.2, sun + 64 sky | {voxels} | {m:.3f} | {g:.3f} | {m / g:.2f} | {err:.2e} |"
    lines.append(row)
    print(row, flush=True)
    lines.append("")
    lines.append("Time per doubling of the resolution (sun only): grid " +
                 ", ".join(f"{b / a:.2f}x" for a, b in zip(scaling["grid"], scaling["grid"][1:])) +
                 "; march " +
                 ", ".join(f"{b / a:.2f}x" for a, b in zip(scaling["march"], scaling["march"][1:])) +
                 " (8x is linear in voxels).")
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
