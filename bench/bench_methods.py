#!/usr/bin/python3
"""Accuracy against time of every bake method (single, pop, fld, svd) beside the Monte-Carlo
reference itself, side by side in one run on the C path: the samples/cloud.json scene (a sun
and a constant sky, g 0.85) at --size; per method and quality the bake + baked-render time and
the image's relative RMSE against a converged reference; the reference's own error at 1, 2, 4,
... spp and its time. Writes a Markdown table and a log-log plot of error against seconds.

usage: bench/bench_methods.py BUILD_DIR [--out bench/methods.md] [--plot bench/methods.png]
       [--size 320x180] [--ref-seconds 120] [--qualities low,medium,high,ultra]
       [--max-spp 256]"""
import argparse
import os
import tempfile

from benchlib import run_json, save_plot, timed

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(os.path.dirname(HERE), "samples", "cloud.json")
METHODS = ["single", "pop", "fld", "svd"]


def read_curves(path):
    """{method: [(seconds, error, quality)]} from a table this script wrote."""
    curves = {}
    for line in open(path):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0] in METHODS + ["reference"]:
            curves.setdefault(cells[0], []).append((float(cells[4]), float(cells[5]), cells[1]))
    return curves


def plot(args, curves):
    def draw(ax):
        for name, pts in curves.items():
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=name)
            for t, e, label in pts:
                if name != "reference":
                    ax.annotate(label, (t, e), fontsize=6, xytext=(3, 3),
                                textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")

    save_plot(args.plot, draw, "seconds (bake + render, or the reference render), C path",
              "image relative RMSE against the converged reference",
              f"samples/cloud.json at {args.size}: accuracy against time")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "methods.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "methods.png"))
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--ref-seconds", type=float, default=120.0)
    ap.add_argument("--qualities", default="low,medium,high,ultra")
    ap.add_argument("--max-spp", type=int, default=256)
    ap.add_argument("--replot", action="store_true",
                    help="redraw --plot from the table in --out without running anything")
    args = ap.parse_args()
    if args.replot:
        plot(args, read_curves(args.out))
        return
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-methods-")
    view = ["--size", args.size]
    ref = os.path.join(tmp, "ref.exr")
    run_json([exe, "render", "--scene", SCENE, "-o", ref, "--mode", "reference", "--time",
              str(args.ref_seconds), *view, "--json", "-q"])
    lines = [f"`bench/bench_methods.py BUILD --size {args.size} --ref-seconds "
             f"{args.ref_seconds:g}` (C path): samples/cloud.json, error = image relative RMSE "
             f"against a {args.ref_seconds:g} s reference; seconds = bake + baked render "
             "(methods) or the reference render at that spp.", "",
             "| method | quality | bake s | render s | total s | error |",
             "|---|---|---|---|---|---|"]
    curves = {}
    for method in METHODS:
        for q in args.qualities.split(","):
            lit = os.path.join(tmp, "lit.vdb")
            img = os.path.join(tmp, "img.exr")
            _, bake_s = timed([exe, "bake", "--scene", SCENE, "-o", lit, "--method", method,
                               "--quality", q, "--backend", "cpu", "--json", "-q"])
            _, render_s = timed([exe, "render", lit, "-o", img, "--backend", "cpu", *view,
                                 "--json", "-q"])
            err = run_json([exe, "compare", img, ref, "--json"])["relrmse"]
            curves.setdefault(method, []).append((bake_s + render_s, err, q))
            row = (f"| {method} | {q} | {bake_s:.2f} | {render_s:.2f} | {bake_s + render_s:.2f} | "
                   f"{err:.3f} |")
            lines.append(row)
            print(row, flush=True)
    spp = 1
    while spp <= args.max_spp:
        out = os.path.join(tmp, "probe.exr")
        _, s = timed([exe, "render", "--scene", SCENE, "-o", out, "--mode", "reference", "--spp",
                      str(spp), "--seed", "11", *view, "--json", "-q"])
        err = run_json([exe, "compare", out, ref, "--json"])["relrmse"]
        curves.setdefault("reference", []).append((s, err, f"{spp} spp"))
        row = f"| reference | {spp} spp | - | {s:.2f} | {s:.2f} | {err:.3f} |"
        lines.append(row)
        print(row, flush=True)
        spp *= 2
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    plot(args, curves)
    print(open(args.out).read())


if __name__ == "__main__":
    main()
