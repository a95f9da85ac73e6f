#!/usr/bin/env python3
"""Frame sequences side by side in one run: a shot of `sample smoke --time` frames baked cold
(--no-warm-start) and warm (each frame from the previous one's state) with SVD and FLD, per
resolution. Reports the iterations of frames 2..N, the wall time of the whole sequence, what
the state costs (its read, its grids' bytes), each result's distance from a tight bake on the
first, middle and last frames, and what a rerun (every frame skipped) and --verify cost.

usage: bench/bench_sequence.py BUILD_DIR [--frames 24] [--res 96,160] [-o bench/sequence.md]
Needs /usr/bin/python3 with numpy and pyopenvdb."""
import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = ["--quality", "low", "--sun", "0.3,-1,0.2:3,3,3", "--env", "0.2,0.3,0.5", "--albedo",
         "0.99", "--g", "0.5", "--density-scale", "30"]
# Per method: its iteration count in the report, and the flag of its tight bake.
METHODS = {
    "svd": (lambda r: r["svd"]["iterations"], ["--residual", "1e-5"]),
    # FLD has no finer stopping flag: its warm result is measured against its cold one
    "fld": (lambda r: r["fld"]["cg_iterations"], None),
}


def run(exe, *args):
    subprocess.run([exe, *map(str, args)], check=True, stdout=subprocess.PIPE,
                   stderr=subprocess.PIPE)


def ms(path):
    g = [x for x in vdb.readAll(path)[0] if x.name == "ms"][0]
    lo, hi = g.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(b - a + 1 for a, b in zip(lo, hi)) + (3,), np.float32)
    g.copyToArray(a, ijk=lo)
    return a


def rel_rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b ** 2)))


# The starts compared: cold, warm, and for SVD cold with a tighter residual (the other way to
# spend on accuracy).
STARTS = {"cold": ["--no-warm-start"], "warm": [],
          "cold, --residual 0.012": ["--no-warm-start", "--residual", "0.012"]}


def bake_sequence(exe, inputs, out, method, start):
    os.makedirs(os.path.dirname(out), exist_ok=True)
    summary = os.path.join(os.path.dirname(out), "summary.json")
    t0 = time.perf_counter()
    run(exe, "bake", inputs, "-o", out, "--method", method, *SCENE, "--summary", summary, "-q",
        *STARTS[start])
    wall = time.perf_counter() - t0
    with open(summary) as f:
        return json.load(f), wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("build")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--res", default="96,160")
    ap.add_argument("-o", "--output", default=os.path.join(HERE, "sequence.md"))
    a = ap.parse_args()
    exe = os.path.join(os.path.abspath(a.build), "vdbscatter")
    n = a.frames
    tmp = tempfile.mkdtemp(prefix="bench_sequence.")
    rows, skip_rows = [], []
    try:
        for res in map(int, a.res.split(",")):
            folder = os.path.join(tmp, str(res))
            os.makedirs(folder)
            for f in range(1, n + 1):
                run(exe, "sample", "smoke", "--res", res, "--time", (f - 1) / (n - 1), "-o",
                    os.path.join(folder, f"in.{f:04d}.vdb"))
            inputs = os.path.join(folder, "in.####.vdb")
            for method, (iterations, tight_flags) in METHODS.items():
                starts = list(STARTS) if method == "svd" else ["cold", "warm"]
                result = {}
                for start in starts:
                    out = os.path.join(folder, f"{method}_{starts.index(start)}", "lit.####.vdb")
                    summary, wall = bake_sequence(exe, inputs, out, method, start)
                    reports = [fr["report"] for fr in summary["frames"]]
                    result[start] = dict(
                        out=out, wall=wall,
                        its=sum(iterations(r) for r in reports[1:]),
                        load=sum(r["seconds"]["load"] for r in reports[1:]),
                        write=sum(r["seconds"]["write"] for r in reports[1:]),
                        bytes=os.path.getsize(out.replace("####", f"{n:04d}")))
                errors = {start: [] for start in starts}
                for f in (3, (n + 1) // 2, n):
                    frame = lambda start: result[start]["out"].replace("####", f"{f:04d}")
                    if tight_flags is None:
                        errors["cold"].append(0.0)
                        errors["warm"].append(rel_rms(ms(frame("warm")), ms(frame("cold"))))
                        continue
                    tight = os.path.join(folder, f"{method}_tight.{f:04d}.vdb")
                    run(exe, "bake", os.path.join(folder, f"in.{f:04d}.vdb"), "-o", tight,
                        "--method", method, *SCENE, *tight_flags, "-q")
                    t = ms(tight)
                    for start in starts:
                        errors[start].append(rel_rms(ms(frame(start)), t))
                for start in starts:
                    r = result[start]
                    rows.append((res, method, start, r["its"], r["wall"], r["load"], r["write"],
                                 r["bytes"] / 2**20, errors[start]))
                # a rerun: every frame up to date; and --verify
                out = result["warm"]["out"]
                t0 = time.perf_counter()
                run(exe, "bake", inputs, "-o", out, "--method", method, *SCENE, "-q")
                rerun = time.perf_counter() - t0
                t0 = time.perf_counter()
                run(exe, "bake", inputs, "-o", out, "--method", method, *SCENE, "--verify", "-q")
                verify = time.perf_counter() - t0
                skip_rows.append((res, method, rerun, verify, result["warm"]["wall"]))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    checked = f"3, {(n + 1) // 2}, {n}"
    lines = [
        "# Frame sequences: warm starts against cold, skipping, verifying",
        "",
        f"`bench/bench_sequence.py`: {n} frames of `sample smoke --time (f-1)/{n - 1}` (a rising "
        "plume whose box grows), `--quality low`, a sun and a sky, albedo 0.99, g 0.5, density "
        "scale 30; cold (`--no-warm-start`) and warm baked side by side in one run on this "
        "machine (2 cores). Iterations and seconds of the state's read and of the writes are "
        f"summed over frames 2-{n} (frame 1 starts cold in both); the error is ms's relative RMS "
        "distance from a tight bake (SVD `--residual 1e-5`; FLD has no finer stopping flag, so "
        f"its warm result is measured against its cold one) on frames {checked}.",
        "",
        "| voxels | method | start | iterations 2-N | sequence s | load s | write s | "
        f"last file MiB | error frames {checked} |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for res, method, start, its, wall, load, write, mib, errs in rows:
        lines.append(f"| {res}^3 | {method} | {start} | {its} | {wall:.1f} | {load:.2f} | "
                     f"{write:.2f} | {mib:.1f} | " + ", ".join(f"{e:.4f}" for e in errs) + " |")
    lines += ["", "Rerunning the warm sequence (every frame up to date: one read of each "
              "output's header) and `--verify`, against baking it:", "",
              "| voxels | method | rerun s | verify s | bake s |", "|---|---|---|---|---|"]
    for res, method, rerun, verify, bake in skip_rows:
        lines.append(f"| {res}^3 | {method} | {rerun:.2f} | {verify:.2f} | {bake:.1f} |")
    with open(a.output, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
