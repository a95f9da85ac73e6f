#!/usr/bin/python3
"""Two builds side by side in one run: the same bakes and renders, alternating A and B,
median of N runs each, on the C path and the compute shader (llvmpipe here).

usage: bench/bench_ab.py BUILD_A BUILD_B [--runs 3] [--out bench/ab.md]
BUILD_* are folders holding a `vdbscatter` executable (e.g. the build before and after a
refactor). Times are the solve / render stage of the --json reports (load and write
excluded); for the FLD and SVD bakes the method's own solve stage (fld_solve, svd_solve: the
S1 pass before it excluded). The table gives B/A per case: 1.00 is the same speed, and what B
moved between host and GPU (the report's `transfer`, where B has it); a second table gives
the shader / C ratio of each FLD and SVD case for A and for B. On a shared machine,
OMP_NUM_THREADS=1 LP_NUM_THREADS=1 in the environment runs both backends on one thread each:
with two, every OpenMP region and llvmpipe dispatch waits for a second thread that other
processes may be holding, and the C path's times multiply."""
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
    # runner's operator (thousands of applications), SVD's sweeps of 64 directions and 8
    # terms on 24 cells at g 0.6 (hundreds of steps per sweep).
    fld = ["--method", "fld", "--fld-res", "48", "--density-scale", "20",
           "--sun", "0.3,-1,0.2:3,3,3"]
    svd = ["--method", "svd", "--svd-res", "24", "--svd-directions", "64", "--svd-terms", "8",
           "--g", "0.6", "--density-scale", "20", "--sun", "0.3,-1,0.2:3,3,3"]
    bake = lambda flags: lambda o, b: ["bake", cloud, "-o", o + ".vdb", "--backend", b, *flags]
    cases = [
        ("bake cloud 96^3, sun + point", "solve", bake(sun)),
        ("bake cloud 96^3, sun + sky 16 dirs", "solve", bake(sky)),
        ("render baked cloud 160x120, quality low", "render",
         lambda o, b: ["render", lit, "-o", o + ".exr", "--backend", b, "--size", "160x120",
                       "--quality", "low"]),
        ("bake cloud 96^3, fld 48 cells, sun", "fld_solve", bake(fld)),
        ("bake cloud 96^3, svd 24 cells 64 dirs 8 terms, sun", "svd_solve", bake(svd)),
    ]
    backends = ("cpu", "gpu")
    rows = {}
    for name, stage, argv in cases:
        # Both backends in every round, so that a shader / C ratio compares runs made close
        # together on a machine whose load changes.
        times = {b: [[], []] for b in backends}
        moved = {b: "-" for b in backends}
        for r in range(args.runs):
            for b in backends:
                for i, exe in enumerate(exes):
                    rep = run_json([exe, *argv(os.path.join(tmp, f"o{i}"), b), "--json", "-q"])
                    times[b][i].append(rep["seconds"][stage])
                    if i == 1 and "transfer" in rep:
                        t = rep["transfer"]
                        moved[b] = (f"{t['uploaded_bytes'] / 1e6:.2f} / "
                                    f"{t['read_back_bytes'] / 1e6:.2f}")
        for b in backends:
            ma, mb = statistics.median(times[b][0]), statistics.median(times[b][1])
            rows[f"{name}, {b}"] = (ma, mb, moved[b])
            print(f"{name}, {b}: A {ma:.3f}s B {mb:.3f}s B/A {mb / ma:.3f}", flush=True)
    threads = os.environ.get("OMP_NUM_THREADS", "default")
    with open(args.out, "w") as f:
        f.write(f"| case (median of {args.runs}; OMP_NUM_THREADS {threads}) | A s | B s | B / A | "
                "B transfer MB (up / back) |\n|---|---|---|---|---|\n")
        for b in backends:
            for name, _, _ in cases:
                ma, mb, m = rows[f"{name}, {b}"]
                f.write(f"| {name}, {b} | {ma:.3f} | {mb:.3f} | {mb / ma:.3f} | {m} |\n")
        f.write("\n| solve | A shader / C | B shader / C |\n|---|---|---|\n")
        for name, stage, _ in cases:
            if stage in ("fld_solve", "svd_solve"):
                gpu, cpu = rows[f"{name}, gpu"], rows[f"{name}, cpu"]
                f.write(f"| {name} | {gpu[0] / cpu[0]:.2f} | {gpu[1] / cpu[1]:.2f} |\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
