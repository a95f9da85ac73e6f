#!/usr/bin/python3
"""Accuracy against time of every bake method (single, pop, fld, svd) beside the Monte-Carlo
reference itself, on the samples/cloud.json scene (a sun and a constant sky, g 0.85) at --size:
one `vdbscatter tradeoff` run (C path), which bakes and renders every method at every quality,
compares each picture with a reference of relative noise --ref-noise and measures the
reference's own error at fewer samples per pixel. Writes a Markdown table and the tradeoff's
log-log plot of error against seconds.

usage: bench/bench_methods.py BUILD_DIR [--out bench/methods.md] [--plot bench/methods.png]
       [--size 320x180] [--ref-noise 0.01] [--qualities low,medium,high,ultra] [--dir DIR]"""
import argparse
import os
import shutil
import tempfile

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(os.path.dirname(HERE), "samples", "cloud.json")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "methods.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "methods.png"))
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--ref-noise", default="0.01")
    ap.add_argument("--ref-time", default="600")
    ap.add_argument("--qualities", default="low,medium,high,ultra")
    ap.add_argument("--dir", default="", help="the tradeoff folder (kept; a rerun reuses its "
                    "reference); default a fresh temporary one")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    work = args.dir or tempfile.mkdtemp(prefix="bench-methods-")
    rep = run_json([exe, "tradeoff", "--scene", SCENE, "-o", work, "--size", args.size,
                    "--qualities", args.qualities, "--ref-noise", args.ref_noise,
                    "--ref-time", args.ref_time, "--backend", "cpu", "--json", "-q"])
    ref = rep["reference"]
    lines = [f"`bench/bench_methods.py BUILD --size {args.size} --ref-noise {args.ref_noise}` "
             "(`vdbscatter tradeoff`, C path): samples/cloud.json; error = image relative RMSE "
             f"against a reference of {ref['spp']} spp (its relative noise {ref['noise']:.4f}, "
             f"removed from the error; {ref['seconds']:.0f} s); seconds = bake + baked render "
             "(methods) or the reference render at that spp.", "",
             "| method | quality | bake s | render s | total s | error | its se |",
             "|---|---|---|---|---|---|---|"]
    for r in rep["rows"]:
        total = r["bake_s"] + r["render_s"]
        lines.append(f"| {r['method']} | {r['quality']} | {r['bake_s']:.2f} | "
                     f"{r['render_s']:.2f} | {total:.2f} | {r['relrmse']:.4f} | "
                     f"{r['relrmse_se']:.4f} |")
    for p in ref["curve"]:
        lines.append(f"| reference | {p['spp']} spp | - | {p['seconds']:.2f} | "
                     f"{p['seconds']:.2f} | {p['relrmse']:.4f} | - |")
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    shutil.copy(os.path.join(work, "tradeoff.png"), args.plot)
    print(open(args.out).read())


if __name__ == "__main__":
    main()
