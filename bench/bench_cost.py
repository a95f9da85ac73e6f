#!/usr/bin/python3
"""The solvers' cost hints (vdbs_solver.cost in solvers/*_entry.c): solve seconds per million
output voxels on the C path, per method and quality, on the bundled cloud under
samples/cloud.json's lights (a sun and a constant sky), median of --runs runs.

usage: bench/bench_cost.py BUILD [--res 48] [--runs 3] [--methods a,b] [--out bench/cost.md]
(--methods: only these rows are measured; the others are kept from the existing table)
Writes a table and the C initialisers to paste into the entries. A hint, not a promise: the
cost follows sky directions, cells and iterations, which differ from scene to scene."""
import argparse
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
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(HERE, "cost.md"))
    ap.add_argument("--methods", default="single,pop,fld,svd,inet")
    args = ap.parse_args()
    measured = args.methods.split(",")
    kept = {}  # rows of the existing table for the methods not measured now
    if os.path.exists(args.out):
        for line in open(args.out):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) == 5 and cells[0] not in ("method", "---") and not cells[0].startswith("-"):
                try:
                    kept[cells[0]] = [float(c) for c in cells[1:]]
                except ValueError:
                    pass
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-cost-")
    cloud = os.path.join(tmp, "cloud.vdb")
    subprocess.run([exe, "sample", "cloud", "--res", str(args.res), "-o", cloud], check=True,
                   capture_output=True)
    scene = os.path.join(ROOT, "samples", "cloud.json")
    rows = []
    for method in ("single", "pop", "fld", "svd", "inet"):
        if method not in measured:
            if method in kept:
                rows.append((method, kept[method]))
            continue
        row = []
        for q in QUALITIES:
            secs, voxels = [], 0
            for _ in range(args.runs):
                rep = run_json([exe, "bake", cloud, "--scene", scene, "-o",
                                os.path.join(tmp, "lit.vdb"), "--method", method, "--quality", q,
                                "--backend", "cpu", "--json", "-q"])
                secs.append(rep["seconds"]["solve"])
                voxels = rep["output_voxels"]
            row.append(statistics.median(secs) / voxels * 1e6)
            print(f"{method} {q}: {row[-1]:.3g} s per million voxels ({voxels} voxels)", flush=True)
        rows.append((method, row))
    with open(args.out, "w") as f:
        f.write(f"`bench/bench_cost.py BUILD --res {args.res} --runs {args.runs}`: solve seconds "
                "per million output voxels, C path, cloud sample under samples/cloud.json's "
                "lights, median of the runs.\n\n| method | " + " | ".join(QUALITIES) +
                " |\n|---|---|---|---|---|\n")
        for method, row in rows:
            f.write(f"| {method} | " + " | ".join(f"{v:.3g}" for v in row) + " |\n")
        f.write("\nAs the entries' `cost` initialisers, each quality at least the one below (a "
                "step that keeps the settings below, such as POP's stopped ladder, measures the "
                "same up to noise, and a hint must not say a higher quality is cheaper):\n\n"
                "```c\n")
        for method, row in rows:
            hint = [max(row[:q + 1]) for q in range(len(row))]
            f.write(f"/* {method} */ .cost = {{" + ", ".join(f"{v:.3g}" for v in hint) + "},\n")
        f.write("```\n")


if __name__ == "__main__":
    main()
