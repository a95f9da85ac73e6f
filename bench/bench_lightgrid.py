#!/usr/bin/python3
"""Single scattering from light grids (bake --s1 grid) against the exact per-voxel march
(--s1 march), side by side in one run, C path: time per doubling of the resolution of the
procedural cloud (sun; sun + 64 sky), the Disney cloud at density scale 0.2 with a sun and a
64-direction sky (time and relative RMSE of radiance over voxels above 1e-3 of the maximum),
the share of the sweep, the lookup and the rest, the sweep's cells per second against the
march's voxel-light pairs per second; and `render` of samples/cloud.json at 640x480 with light
marches (before) and light grids.

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
    return rep


def stages(rep):
    """Shares of the solve in the sweep, the lookup and the rest, and the sweep's cells/s."""
    t = rep["seconds"]
    sweep, lookup, solve = t["s1_sweep"], t["s1_lookup"], t["solve"]
    rest = max(solve - sweep - lookup, 0.0)
    return (f"{100 * sweep / solve:.0f}% / {100 * lookup / solve:.0f}% / {100 * rest / solve:.0f}%",
            rep["light_grids"]["cells"] / sweep)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "lightgrid.md"))
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-lightgrid-")
    sun = ["--density-scale", "20", "--sun", "0.3,-1,0.2"]
    sky = sun + ["--env", "0.2,0.3,0.5", "--quality", "medium"]
    lines = ["| case | output voxels | march s | grid s | march / grid | grid relative RMSE | "
             "grid: sweep / lookup / rest | sweep cells/s | march voxel-lights/s |",
             "|---|---|---|---|---|---|---|---|---|"]
    scaling = {"march": [], "grid": [], "grid_sky": [], "march_sky": []}

    def row(label, src, light, lights_count, with_march=True):
        rg = bake(exe, src, os.path.join(tmp, "g.vdb"), "grid", light)
        g, voxels = rg["seconds"]["solve"], rg["output_voxels"]
        share, cells_per_s = stages(rg)
        if with_march:
            rm = bake(exe, src, os.path.join(tmp, "m.vdb"), "march", light)
            m = rm["seconds"]["solve"]
            err = relrmse(radiance(os.path.join(tmp, "g.vdb")), radiance(os.path.join(tmp, "m.vdb")))
            text = (f"| {label} | {voxels} | {m:.3f} | {g:.3f} | {m / g:.2f} | {err:.2e} | {share} | "
                    f"{cells_per_s:.3g} | {voxels * lights_count / m:.3g} |")
        else:
            m = None
            text = f"| {label} | {voxels} | (not run) | {g:.3f} | | | {share} | {cells_per_s:.3g} | |"
        lines.append(text)
        print(text, flush=True)
        return g, m

    for res in [64, 128, 256]:
        src = os.path.join(tmp, f"cloud{res}.vdb")
        subprocess.run([exe, "sample", "cloud", "--res", str(res), "-o", src], check=True)
        g, m = row(f"cloud {res}^3, sun", src, sun, 1)
        scaling["grid"].append(g)
        scaling["march"].append(m)
    for res in [64, 128, 256]:
        src = os.path.join(tmp, f"cloud{res}.vdb")
        g, m = row(f"cloud {res}^3, sun + 64 sky", src, sky, 65, with_march=res <= 128)
        scaling["grid_sky"].append(g)
        scaling["march_sky"].append(m)
    wdas = os.path.join(DATA, "wdas_cloud_sixteenth.vdb")
    extra = ["--density-scale", "0.2", "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5",
             "--quality", "medium"]
    row("wdas_cloud_sixteenth at 0.2, sun + 64 sky", wdas, extra, 65)
    lines.append("")

    def per_doubling(times):
        return ", ".join(f"{b / a:.2f}x" for a, b in zip(times, times[1:]) if a and b)

    lines.append(f"Time per doubling of the resolution: sun only: grid {per_doubling(scaling['grid'])}; "
                 f"march {per_doubling(scaling['march'])}. Sun + 64 sky: grid "
                 f"{per_doubling(scaling['grid_sky'])}; march {per_doubling(scaling['march_sky'])} "
                 "(8x is linear in voxels).")
    lines.append("")

    # render of samples/cloud.json at 640x480: the exact light marches (before) and light grids
    lines.append("| render of samples/cloud.json, 640x480, single | light marches s | light grids s | "
                 "marches / grids | grids: sweep / camera rays | relative RMSE |")
    lines.append("|---|---|---|---|---|---|")
    scene = os.path.join(ROOT, "samples", "cloud.json")
    imgs = {}
    times = {}
    for s1 in ["march", "grid"]:
        imgs[s1] = os.path.join(tmp, f"render_{s1}.exr")
        times[s1] = run_json([exe, "render", "--scene", scene, "-o", imgs[s1], "--size", "640x480",
                              "--backend", "cpu", "--s1", s1, "--json", "-q"])["seconds"]
    err = run_json([exe, "compare", imgs["grid"], imgs["march"], "--json"])["relrmse"]
    tg, tm = times["grid"], times["march"]
    text = (f"| sun + 64 sky, g 0.85 | {tm['render']:.2f} | {tg['render']:.2f} | "
            f"{tm['render'] / tg['render']:.2f} | {tg['s1_sweep']:.2f} s / {tg['march']:.2f} s | "
            f"{err:.2e} |")
    lines.append(text)
    print(text, flush=True)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
