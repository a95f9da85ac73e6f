#!/usr/bin/python3
"""The solvers' cost hints (vdbs_solver.cost and .cost_fixed in solvers/*_entry.c): solve
seconds per million output voxels, and seconds per solve that do not follow the voxels, on the
C path, per method and quality, on the bundled cloud under samples/cloud.json's lights (a sun
and a constant sky), median of --runs runs.

usage: bench/bench_cost.py BUILD [--res 48] [--res2 0] [--runs 3] [--methods a,b]
       [--out bench/cost.md]
(--methods: only these rows are measured; the others are kept from the existing table.
--res2 R: also at resolution R, and the two sizes give a line, fixed + per voxel; without it
the fixed part is 0.) Writes a table and the C initialisers to paste into the entries. A
hint, not a promise: the cost follows sky directions, cells and iterations, which differ from
scene to scene."""
import argparse
import datetime
import os
import statistics
import subprocess
import tempfile

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
QUALITIES = ["low", "medium", "high", "ultra"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--res", type=int, default=48)
    ap.add_argument("--res2", type=int, default=0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(HERE, "cost.md"))
    ap.add_argument("--methods", default="single,pop,fld,svd,inet")
    args = ap.parse_args()
    measured = args.methods.split(",")
    # Rows of the existing table for the methods not measured now, each with its own note of
    # how and when it was measured (the last cell).
    kept = {}
    if os.path.exists(args.out):
        for line in open(args.out):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) == 10 and cells[0] != "method" and not cells[0].startswith("-"):
                try:
                    v = [float(c) for c in cells[1:9]]
                except ValueError:
                    continue
                kept[cells[0]] = (v[:4], v[4:], cells[9])
    how = (f"--res {args.res}{f' --res2 {args.res2}' if args.res2 else ''} --runs {args.runs}, "
           f"{datetime.date.today().isoformat()}")
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-cost-")
    scene = os.path.join(ROOT, "samples", "cloud.json")
    clouds = []
    for res in [args.res] + ([args.res2] if args.res2 else []):
        clouds.append(os.path.join(tmp, f"cloud{res}.vdb"))
        subprocess.run([exe, "sample", "cloud", "--res", str(res), "-o", clouds[-1]], check=True,
                       capture_output=True)

    def measure(cloud, method, q):
        """(median solve seconds, output voxels)"""
        secs, voxels = [], 0
        for _ in range(args.runs):
            rep = run_json([exe, "bake", cloud, "--scene", scene, "-o",
                            os.path.join(tmp, "lit.vdb"), "--method", method, "--quality", q,
                            "--backend", "cpu", "--json", "-q"])
            secs.append(rep["seconds"]["solve"])
            voxels = rep["output_voxels"]
        return statistics.median(secs), voxels

    rows = []
    for method in ("single", "pop", "fld", "svd", "inet"):
        if method not in measured:
            if method in kept:
                rows.append((method,) + kept[method])
            continue
        per_voxel, fixed = [], []
        for q in QUALITIES:
            points = [measure(cloud, method, q) for cloud in clouds]
            (s1, v1), (s2, v2) = points[0], points[-1]
            slope = (s2 - s1) / (v2 - v1) if v2 != v1 else s1 / v1
            # A line through two noisy points: neither part may go below 0.
            if slope * v1 > s1:
                slope = s1 / v1
            if slope < 0.0:
                slope = 0.0
            per_voxel.append(slope * 1e6)
            fixed.append(max(s1 - slope * v1, 0.0))
            print(f"{method} {q}: {per_voxel[-1]:.3g} s per million voxels + {fixed[-1]:.3g} s "
                  f"({', '.join(f'{s:.2f} s at {v} voxels' for s, v in points)})", flush=True)
        rows.append((method, per_voxel, fixed, how))
    with open(args.out, "w") as f:
        f.write("`bench/bench_cost.py BUILD [--res N] [--res2 M] [--runs K] [--methods M,...]`: "
                "solve seconds per million output voxels, and seconds per solve that do not "
                "follow the voxels (fixed; from two volume sizes, 0 where measured at one), C "
                "path, cloud sample under samples/cloud.json's lights, median of the runs. "
                "`--methods` measures those rows again and keeps the others; the last column "
                "says how and when each row was measured.\n\n"
                "| method | " + " | ".join(QUALITIES) + " | " +
                " | ".join(f"fixed {q}" for q in QUALITIES) + " | measured |\n|---" +
                "|---" * 9 + "|\n")
        for method, row, fixed, note in rows:
            f.write(f"| {method} | " + " | ".join(f"{v:.3g}" for v in row + fixed) +
                    f" | {note} |\n")
        f.write("\nAs the entries' `cost` initialisers, each quality at least the one below (a "
                "step that keeps the settings below, such as POP's stopped ladder, measures the "
                "same up to noise, and a hint must not say a higher quality is cheaper):\n\n"
                "```c\n")
        for method, row, fixed, _ in rows:
            hint = [max(row[:q + 1]) for q in range(len(row))]
            f.write(f"/* {method} */ .cost = {{" + ", ".join(f"{v:.3g}" for v in hint) + "},\n")
            if any(fixed):
                hint = [max(fixed[:q + 1]) for q in range(len(fixed))]
                f.write(f"/* {method} */ .cost_fixed = {{" + ", ".join(f"{v:.3g}" for v in hint) +
                        "},\n")
        f.write("```\n")


if __name__ == "__main__":
    main()
