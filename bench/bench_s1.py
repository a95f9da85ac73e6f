#!/usr/bin/python3
"""S1 cost with light grids sized to the light (lightgrid.h: sky ordinates spaced by the sky's
share of the light), C path, side by side in one run:

1. the Disney cloud (wdas_cloud_sixteenth, density scale 0.2, a sun of 1 and a 64-direction
   constant sky 0.2,0.3,0.5: --quality medium, oversample 1, --method single --store none):
   the exact march (--s1 march), then light grids: a `--before` build (the sizing and the
   batched lookups absent), the sky at fixed spacings (--s1-sky-spacing, voxels) and the
   default rule; time of the solve (from the bake's --json), its sweep and lookup, and the
   relative RMSE of the radiance grid (S1) against the march's over voxels above 1e-3 of the
   maximum; the same with the sky at a tenth (--sky-alone: also the sky without the sun);
2. the largest volume of the data folder (by active voxels, `vdbscatter info`): S1 time with
   the default grids; the march on a sun and 4 sky directions, scaled to 65 lights by its
   time per light (the march is linear in the lights).

usage: bench/bench_s1.py BUILD_DIR [--out bench/s1.md] [--data DIR] [--before EXE]"""
import argparse
import os
import tempfile

import numpy as np

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def radiance(path):
    import pyopenvdb
    grid = pyopenvdb.read(path, "radiance")
    return np.array([v.value for v in grid.citerOnValues()], dtype=np.float64).reshape(-1)


def relrmse(a, b):
    mask = b > 1e-3 * b.max()
    return float(np.sqrt(np.sum((a[mask] - b[mask]) ** 2) / np.sum(b[mask] ** 2)))


def bake(exe, src, out, extra):
    return run_json([exe, "bake", src, "-o", out, "--backend", "cpu", "--method", "single",
                     "--store", "none", "--json", "-q", *extra])


def kinds(rep):
    """'sun 1 x 1.00 / sky 64 x 2.00-2.00' style: lights and spacings in voxels."""
    out = []
    for k in rep.get("s1_grids_per_kind", []):
        out.append(f"{k['kind']} {k['lights']}: {k['spacing_min']:.3g}-{k['spacing_max']:.3g}")
    return "; ".join(out)


def largest(exe, data):
    best = None
    for name in sorted(os.listdir(data)):
        if not name.endswith(".vdb"):
            continue
        p = run_json_quiet([exe, "info", os.path.join(data, name), "--json"])
        if not p:
            continue
        voxels = max([g.get("active_voxels", 0) for g in p.get("grids", [])] or [0])
        if best is None or voxels > best[1]:
            best = (name, voxels)
    return best


def run_json_quiet(cmd):
    import json
    import subprocess
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return None
    return json.loads(p.stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "s1.md"))
    ap.add_argument("--data", default=os.environ.get("VDBSCATTER_DATA_DIR",
                                                     os.path.join(ROOT, "..", "shared", "data")))
    ap.add_argument("--spacings", default="1,2,4")
    ap.add_argument("--sky-alone", action="store_true",
                    help="also the 64 sky directions without the sun")
    ap.add_argument("--no-largest", action="store_true")
    ap.add_argument("--before", help="a vdbscatter before the sizing and the batched lookups "
                    "(e.g. main's build): its grid row in the same run")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-s1-")
    wdas = os.path.join(args.data, "wdas_cloud_sixteenth.vdb")
    if not os.path.exists(wdas):
        raise SystemExit(f"no {wdas}: nothing to measure")
    medium = ["--density-scale", "0.2", "--quality", "medium"]
    sun = ["--sun", "0.3,-1,0.2"]
    sky = ["--env", "0.2,0.3,0.5"]
    spacings = [float(s) for s in args.spacings.split(",")]
    lines = ["# S1 with light grids sized to the light", "",
             "Rows: `before` is the build before the sizing and the batched lookups (sky at 1 "
             "voxel, lookups light by light); a number is `--s1-sky-spacing` in voxels; `rule` "
             "the default sizing. Grids: kind, lights, spacing (world; a voxel is 3.33).", "",
             "`bench/bench_s1.py` (C path, one run). Disney cloud (wdas_cloud_sixteenth, 504k "
             "output voxels) at density scale 0.2, `--quality medium` (64 sky directions, "
             "oversample 1), `--method single --store none`; relative RMSE of `radiance` against "
             "`--s1 march` of the same lights over voxels above 1e-3 of the maximum.", ""]

    # The goal case (the sky 81% of the light), and its sky at a tenth (30%).
    cases = [("sun + 64 sky", sun + sky), ("sun + 64 sky at a tenth", sun + ["--env", "0.02,0.03,0.05"])]
    cases += [("64 sky alone", sky)] if args.sky_alone else []
    for label, lights in cases:
        m = bake(exe, wdas, os.path.join(tmp, "m.vdb"), medium + lights + ["--s1", "march"])
        ref = radiance(os.path.join(tmp, "m.vdb"))
        tm = m["seconds"]["solve"]
        lines += [f"## {label}", "",
                  f"March: {tm:.2f} s.", "",
                  "| sky spacing (voxels) | grids (spacing, voxels) | solve s | sweep s | "
                  "lookup s | march / grid | relative RMSE | cells |",
                  "|---|---|---|---|---|---|---|---|"]
        print(lines[-4], flush=True)
        runs = ([("before", None)] if args.before else []) + [(f"{s:g}", s) for s in spacings + [0]]
        for name, s in runs:
            extra = ["--s1-sky-spacing", str(s)] if s else []
            g = bake(args.before if s is None else exe, wdas, os.path.join(tmp, "g.vdb"),
                     medium + lights + extra)
            err = relrmse(radiance(os.path.join(tmp, "g.vdb")), ref)
            t = g["seconds"]
            row = (f"| {name} | {kinds(g) or 'sun and sky: 1 voxel'} | {t['solve']:.2f} | {t['s1_sweep']:.2f} | "
                   f"{t['s1_lookup']:.2f} | {tm / t['solve']:.1f}x | {err:.2e} | "
                   f"{g['light_grids']['cells']:.3g} |")
            if s == 0:
                row = row.replace("| 0 |", "| rule (default) |", 1)
            lines.append(row)
            print(row, flush=True)
        lines.append("")

    big = None if args.no_largest else largest(exe, args.data)
    if big:
        name, voxels = big
        src = os.path.join(args.data, name)
        extra = medium[2:] + sun + sky  # its own density
        g = bake(exe, src, os.path.join(tmp, "g.vdb"), extra)
        few = bake(exe, src, os.path.join(tmp, "m.vdb"),
                   extra + ["--sky-directions", "4", "--s1", "march"])
        per_light = few["seconds"]["solve"] / 5
        est = per_light * 65
        t = g["seconds"]
        lines += [f"## The largest volume: {name} ({voxels} active voxels)", "",
                  "Sun + 64 sky at `--quality medium`, its own density. The march's 65 lights are "
                  "estimated from a timed march of a sun and 4 sky directions (5 lights; the "
                  "march is linear in the lights).", "",
                  "| output voxels | grid solve s | sweep s | lookup s | grids | march s (5 lights) "
                  "| march s (65, estimated) | march / grid |",
                  "|---|---|---|---|---|---|---|---|",
                  f"| {g['output_voxels']} | {t['solve']:.2f} | {t['s1_sweep']:.2f} | "
                  f"{t['s1_lookup']:.2f} | {kinds(g)} | {few['seconds']['solve']:.2f} | {est:.1f} | "
                  f"{est / t['solve']:.1f}x |", ""]
        print(lines[-2], flush=True)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
