#!/usr/bin/python3
"""POP: image error against the Monte-Carlo reference per --pop-res (and per quality),
side by side with the single-scattering bake, on the sphere and cloud samples (albedo 0.99, a
sun and a constant sky) for g = 0, 0.5, 0.85, and on the POP check scene (the cloud sample,
density 25, albedo 0.99, g 0.85, one sun straight down). C path. Writes a Markdown table and a
PNG plot of error against cells across.

usage: bench/bench_pop.py BUILD_DIR [--out bench/pop.md] [--plot bench/pop_error.png]
       [--res 4,8,16,32] [--qualities low,...] [--ref-seconds 40] [--size 96x72]
       [--cases all|check|sun-sky] [--tallies chord,cell] [--variant LABEL=FLAGS ...]
Each resolution is baked with every --pop-tally listed (columns "POP r" for the first, the
default chord, and "POP r cell" for the paper's tally), and with each --variant's extra flags
(e.g. --variant "paper=--pop-decay paper": columns "POP r paper"). With --qualities, POP at the default resolution is also baked at each quality (columns
"POP <quality>"), beside the --pop-res columns."""
import argparse
import os
import tempfile

from benchlib import baked_error, case_reference, save_plot

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")

SUN_SKY = ["--sun", "0.3,-1,0.2:3,2.9,2.7", "--env", "0.2,0.3,0.5"]
CASES = [
    # (label, sample, density scale, g, lights)
    ("check: cloud, 25, g 0.85, sun down", "cloud", 25, 0.85, ["--sun", "0,-1,0:3,3,3"]),
    ("sphere, 3, g 0", "sphere", 3, 0.0, SUN_SKY),
    ("sphere, 3, g 0.5", "sphere", 3, 0.5, SUN_SKY),
    ("sphere, 3, g 0.85", "sphere", 3, 0.85, SUN_SKY),
    ("cloud, 20, g 0", "cloud", 20, 0.0, SUN_SKY),
    ("cloud, 20, g 0.5", "cloud", 20, 0.5, SUN_SKY),
    ("cloud, 20, g 0.85", "cloud", 20, 0.85, SUN_SKY),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "pop.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "pop_error.png"))
    ap.add_argument("--res", default="4,8,16,32")
    ap.add_argument("--ref-seconds", type=float, default=40.0)
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--cases", default="all")
    ap.add_argument("--qualities", default="")
    ap.add_argument("--tallies", default="chord")
    ap.add_argument("--variant", action="append", default=[])
    ap.add_argument("--quality-plot", default=os.path.join(HERE, "pop_quality.png"))
    ap.add_argument("--replot-qualities", default="",
                    help="only plot error against quality from a table this bench wrote")
    args = ap.parse_args()
    if args.replot_qualities:
        plot_qualities(read_quality_table(args.replot_qualities), args.quality_plot)
        return
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-pop-")
    resolutions = [int(x) for x in args.res.split(",")]
    cases = {"check": CASES[:1], "sun-sky": CASES[1:]}.get(args.cases, CASES)
    qualities = [q for q in args.qualities.split(",") if q]
    tallies = args.tallies.split(",")
    # (label, bake flags) per column group: the tallies, then the variants.
    groups = [("" if t == tallies[0] else f" {t}", ["--pop-tally", t]) for t in tallies]
    for v in args.variant:
        name, flags = v.split("=", 1)
        groups.append((f" {name}", flags.split()))
    labels = [f"POP {r}{suffix}" for suffix, _ in groups for r in resolutions]
    header = ("| scene | reference se | single | " +
              " | ".join(labels + [f"POP {q}" for q in qualities]) +
              " | POP s at " + str(resolutions[-1]) + " |")
    lines = [header, "|" + "---|" * (4 + len(labels) + len(qualities))]
    curves = []
    quality_rows = []
    for case in cases:
        label = case[0]
        vdb, medium, view, ref = case_reference(exe, tmp, SAMPLES, case, args.size,
                                                args.ref_seconds)

        def error(method, extra):
            e, se, rep = baked_error(exe, vdb, ref, tmp, medium, view, method, extra)
            return e, se, rep["seconds"]["solve"]

        single, se, _ = error("single", [])
        errs = []
        seconds = 0.0
        for suffix, flags in groups:
            for r in resolutions:
                e, _, seconds = error("pop", ["--pop-res", str(r), *flags])
                errs.append(e)
                print(f"  {label}: single {single:.3f}, POP {r}{suffix}: {e:.3f} "
                      f"({seconds:.1f} s)", flush=True)
        quality_errs = []
        for q in qualities:
            e, _, _ = error("pop", ["--quality", q])
            quality_errs.append(e)
            print(f"  {label}: POP at quality {q}: {e:.3f}", flush=True)
        row = (f"| {label} | {se:.4f} | {single:.3f} | " +
               " | ".join(f"{e:.3f}" for e in errs + quality_errs) + f" | {seconds:.1f} |")
        lines.append(row)
        print(row, flush=True)
        curves.append((label, single, errs))
        quality_rows.append((label, single, list(zip(qualities, quality_errs))))
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    if qualities:
        plot_qualities(quality_rows, args.quality_plot)
    def draw(ax):
        for label, single, errs in curves:
            line, = ax.plot(resolutions, errs[:len(resolutions)], marker="o", label=label)
            for k in range(1, len(groups)):
                ax.plot(resolutions, errs[k * len(resolutions):(k + 1) * len(resolutions)],
                        marker="x", linestyle="--", color=line.get_color(), linewidth=0.8)
            ax.axhline(single, color=line.get_color(), linestyle=":", linewidth=0.8)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")

    save_plot(args.plot, draw, "--pop-res (cells across the largest extent)",
              "image relative RMSE against the reference",
              "POP error (dashed:" + ",".join(g[0] for g in groups[1:]) +
              "; dotted: single-scattering bake)" if len(groups) > 1 else
              "POP error (dotted: single-scattering bake)")
    print(open(args.out).read())


def read_quality_table(path):
    """(label, single, [(quality, error)]) per row of a table written with --qualities."""
    rows = []
    header = None
    for line in open(path):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0] == "scene":
            header = cells
        elif header and not cells[0].startswith("---"):
            pairs = [(h[4:], float(v)) for h, v in zip(header, cells)
                     if h.startswith("POP ") and h[4:] in ("low", "medium", "high", "ultra")]
            rows.append((cells[0], float(cells[2]), pairs))
    return rows


def plot_qualities(rows, path):
    """Error against --quality per scene (the single-only bake dotted)."""
    def draw(ax):
        for label, single, pairs in rows:
            line, = ax.plot([q for q, _ in pairs], [e for _, e in pairs], marker="o",
                            label=label)
            ax.axhline(single, color=line.get_color(), linestyle=":", linewidth=0.8)

    save_plot(path, draw, "--quality", "image relative RMSE against the reference",
              "POP error per quality at the default resolution (dotted: single scattering)")


if __name__ == "__main__":
    main()
