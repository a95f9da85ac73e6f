#!/usr/bin/python3
"""First collisions averaged over the voxel, before and after: FLD and SVD at low and medium
(`vdbscatter tradeoff --methods fld,svd`) on every calibration and held-out scene, two builds
side by side against the same references (the calibration's cache, bench_calibrate.py: a
scene's reference is rendered once and reused by both builds). Writes
bench/first_collisions.md.

usage: bench/bench_collisions.py BEFORE_BUILD AFTER_BUILD [--scenes a,b] [--size 96x72]
       [--cache DIR]"""
import argparse
import csv
import os

from bench_calibrate import CALIBRATION, VALIDATION
from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))


def errors(exe, scene, vdb, work, size):
    """{(method, quality): (relrmse, se, mean ratio, seconds)} of one build on one scene."""
    inp = [vdb] if vdb else []
    run_json([exe, "tradeoff", *inp, "--scene", scene, "-o", work, "--size", size,
              "--ref-noise", "0.01", "--ref-time", "240", "--methods", "fld,svd",
              "--qualities", "low,medium", "--json", "-q"])
    out = {}
    with open(os.path.join(work, "tradeoff.csv")) as f:
        for row in csv.DictReader(f):
            if row["method"] in ("fld", "svd"):
                out[(row["method"], row["quality"])] = (
                    float(row["relrmse"]), float(row["relrmse_se"]), float(row["mean_ratio"]),
                    float(row["total_s"]))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--scenes", default="")
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--cache", default=os.path.join("/tmp", "vdbscatter-calibration"))
    args = ap.parse_args()
    wanted = set(args.scenes.split(",")) if args.scenes else None
    lines = ["# First collisions averaged over the voxel: before and after", "",
             f"`bench/bench_collisions.py BEFORE AFTER` ({args.size}, every scene's reference "
             "shared by both builds): relative RMSE ± its standard error from the reference's "
             "noise, and the image's mean ratio to the reference, for FLD and SVD at low and "
             "medium. docs/design.md \"First collisions\" says what changed.", "",
             "| scene | method | quality | before | after | mean ratio before / after |",
             "|---|---|---|---|---|---|"]
    for table in (CALIBRATION, VALIDATION):
        for name, (scene, vdb, _what) in table.items():
            if (wanted and name not in wanted) or (vdb is not None and not os.path.exists(vdb)):
                continue
            work = os.path.join(args.cache, name)
            got = [errors(os.path.join(b, "vdbscatter"), scene, vdb, work, args.size)
                   for b in (args.before, args.after)]
            for key in sorted(got[0]):
                a, b = got[0][key], got[1][key]
                lines.append(f"| {name} | {key[0]} | {key[1]} | {a[0]:.4f} ± {a[1]:.4f} | "
                             f"{b[0]:.4f} ± {b[1]:.4f} | {a[2]:.3f} / {b[2]:.3f} |")
                print(lines[-1], flush=True)
    with open(os.path.join(HERE, "first_collisions.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
