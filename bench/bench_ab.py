#!/usr/bin/python3
"""Two builds side by side in one run: the same bakes and renders, alternating A and B,
median of N runs each, on the C path and the compute shader (llvmpipe here).

usage: bench/bench_ab.py BUILD_A BUILD_B [--runs 3] [--out bench/ab.md]
BUILD_* are folders holding a `vdbscatter` executable (e.g. the build before and after a
refactor). Times are the solve / render stage of the --json reports (load and write
excluded); for the FLD and SVD bakes the method's own solve stage (fld_solve, svd_solve: the
S1 pass before it excluded). The table gives B/A per case: 1.00 is the same speed, and what B
moved between host and GPU (the report's `transfer`, where B has it); a second table gives
the shader / C ratio of each FLD and SVD case for A and for B."""
import argparse
import os
import statistics
import subprocess
import tempfile

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(HERE, "ab.md"))
    args = ap.parse_args()
    exes = [os.path.join(args.a, "vdbscatter"), os.path.join(args.b, "vdbscatter")]
    tmp = tempfile.mkdtemp(prefix="bench-ab-")
    cloud = os.path.join(tmp, "cloud96.vdb")
    subprocess.run([exes[0], "sample", "cloud", "--res", "96", "-o", cloud], check=True)
    scene = os.path.join(ROOT, "samples", "cloud.json")
    lit = os.path.join(tmp, "lit.vdb")
    run_json([exes[0], "bake", "--scene", scene, "-o", lit, "--json", "-q", "--quality", "low"])
    sun = ["--density-scale", "20", "--sun", "0.3,-1,0.2:3,3,3", "--point", "0.2,0.9,0.1:2,2,2"]
    sky = ["--density-scale", "20", "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--quality", "low"]
    # The iterative solvers' own solves: FLD with every level of 48 cells across through the
    # runner's operator (thousands of applications), SVD's sweeps at the low quality's 32
    # directions on 24 cells.
    fld = ["--method", "fld", "--fld-res", "48", "--density-scale", "20",
           "--sun", "0.3,-1,0.2:3,3,3"]
    svd = ["--method", "svd", "--svd-res", "24", "--quality", "low", "--density-scale", "20",
           "--sun", "0.3,-1,0.2:3,3,3"]
    cases = []
    for backend in ("cpu", "gpu"):
        cases += [
            (f"bake cloud 96^3, sun + point, {backend}", backend, "solve",
             lambda e, o, b=backend: ["bake", cloud, "-o", o + ".vdb", "--backend", b, *sun]),
            (f"bake cloud 96^3, sun + sky 16 dirs, {backend}", backend, "solve",
             lambda e, o, b=backend: ["bake", cloud, "-o", o + ".vdb", "--backend", b, *sky]),
            (f"render baked cloud 160x120, quality low, {backend}", backend, "render",
             lambda e, o, b=backend: ["render", lit, "-o", o + ".exr", "--backend", b,
                                      "--size", "160x120", "--quality", "low"]),
            (f"bake cloud 96^3, fld 48 cells, sun, {backend}", backend, "fld_solve",
             lambda e, o, b=backend: ["bake", cloud, "-o", o + ".vdb", "--backend", b, *fld]),
            (f"bake cloud 96^3, svd 24 cells 32 dirs, sun, {backend}", backend, "svd_solve",
             lambda e, o, b=backend: ["bake", cloud, "-o", o + ".vdb", "--backend", b, *svd]),
        ]
    rows = {}
    for name, backend, stage, argv in cases:
        times, moved = [[], []], "-"
        for r in range(args.runs):
            for i, exe in enumerate(exes):
                rep = run_json([exe, *argv(exe, os.path.join(tmp, f"o{i}")), "--json", "-q"])
                times[i].append(rep["seconds"][stage])
                if i == 1 and "transfer" in rep:
                    t = rep["transfer"]
                    moved = f"{t['uploaded_bytes'] / 1e6:.2f} / {t['read_back_bytes'] / 1e6:.2f}"
        ma, mb = statistics.median(times[0]), statistics.median(times[1])
        rows[name] = (ma, mb, moved)
        print(f"{name}: A {ma:.3f}s B {mb:.3f}s B/A {mb / ma:.3f}", flush=True)
    with open(args.out, "w") as f:
        f.write(f"| case (median of {args.runs}) | A s | B s | B / A | B transfer MB "
                "(up / back) |\n|---|---|---|---|---|\n")
        for name, (ma, mb, moved) in rows.items():
            f.write(f"| {name} | {ma:.3f} | {mb:.3f} | {mb / ma:.3f} | {moved} |\n")
        f.write("\n| solve | A shader / C | B shader / C |\n|---|---|---|\n")
        for name in rows:
            if name.endswith(", gpu") and ("fld" in name or "svd" in name):
                gpu, cpu = rows[name], rows[name[:-len("gpu")] + "cpu"]
                f.write(f"| {name[:-len(', gpu')]} | {gpu[0] / cpu[0]:.2f} | "
                        f"{gpu[1] / cpu[1]:.2f} |\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
