#!/usr/bin/python3
"""FLD: image error against the Monte-Carlo reference on the sphere and cloud samples
(albedo 0.99, a sun and a constant sky; g = 0, 0.5, 0.85: bench_pop.py's scenes), beside the
single-scattering bake and POP at its defaults: FLD at its defaults with its grid at the
voxels / 2x / 4x coarser (--fld-res), and at the voxels without the first-moment source
(--fld-p1 off), without ms_l1 from the flux (--fld-l1 off) and without the limiter.
C path, quality medium. Writes a Markdown table and a PNG of error against cells across.

usage: bench/bench_fld.py BUILD_DIR [--out bench/fld.md] [--plot bench/fld_error.png]
       [--ref-seconds 40] [--size 96x72] [--quality medium]"""
import argparse
import os
import tempfile

from bench_pop import CASES, SAMPLES
from benchlib import baked_error, case_reference, run_json, save_plot

HERE = os.path.dirname(os.path.abspath(__file__))
VOXELS = {"sphere": 32, "cloud": 64}  # voxels across the samples' largest extent


def refine(exe, tmp, args, lines):
    """FLD on the cloud at g 0 and 0.85 as the grid is refined: the error against the
    reference, the difference to the finest grid's image (does FLD converge with the grid?)
    and the image's mean over the reference's (where does the error go?)."""
    res = [int(r) for r in args.refine.split(",") if r]
    lines += ["", "Refinement (cloud, density 20, sun and sky; FLD at its defaults but "
              "--fld-res): error against the reference, relative RMSE against the finest "
              "grid's image, and the image's mean over the reference's.", "",
              "| scene | " + " | ".join(f"{r} cells" for r in res) + " |",
              "|---" * (1 + len(res)) + "|"]
    for case in (CASES[4], CASES[6]):
        vdb, medium, view, ref = case_reference(exe, tmp, SAMPLES, case, args.size,
                                                args.ref_seconds)
        images, errs, means = [], [], []
        for r in res:
            img = os.path.join(tmp, f"refine{r}.exr")
            lit = os.path.join(tmp, "lit.vdb")
            run_json([exe, "bake", vdb, "-o", lit, "--backend", "cpu", "--method", "fld",
                      "--quality", args.quality, "--fld-res", str(r), *medium, "--json", "-q"])
            run_json([exe, "render", lit, "-o", img, "--backend", "cpu", *view, "--json", "-q"])
            cmp = run_json([exe, "compare", img, ref, "--json"])
            errs.append(cmp["relrmse"])
            means.append(cmp["mean_ratio"])
            images.append(img)
        to_finest = [run_json([exe, "compare", img, images[-1], "--json"])["relrmse"]
                     for img in images]
        label = case[0]
        lines.append(f"| {label}: error | " + " | ".join(f"{e:.3f}" for e in errs) + " |")
        lines.append(f"| {label}: to the finest | " +
                     " | ".join(f"{e:.3f}" for e in to_finest) + " |")
        lines.append(f"| {label}: mean / reference | " +
                     " | ".join(f"{m:.3f}" for m in means) + " |")
        print("\n".join(lines[-3:]), flush=True)


def read_curves(path):
    """(label, single, pop, cells, errors) per scene row of a table this script wrote."""
    curves = []
    for line in open(path):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 7 or not cells[0].startswith(("sphere", "cloud")) or ":" in cells[0]:
            continue
        n = VOXELS["sphere" if cells[0].startswith("sphere") else "cloud"]
        curves.append((cells[0], float(cells[2]), float(cells[3]), [n // 4, n // 2, n],
                       [float(c) for c in cells[4:7]]))
    return curves


def plot(path, curves):
    def draw(ax):
        for label, single, pop, res, errs in curves:
            line, = ax.plot(res, errs, marker="o", label=label)
            ax.axhline(pop, color=line.get_color(), linestyle="--", linewidth=0.8)
            ax.axhline(single, color=line.get_color(), linestyle=":", linewidth=0.8)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")

    if curves:
        save_plot(path, draw, "--fld-res (cells across the largest extent)",
                  "image relative RMSE against the reference",
                  "FLD error (dashed: POP at its defaults; dotted: single scattering)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "fld.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "fld_error.png"))
    ap.add_argument("--ref-seconds", type=float, default=40.0)
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--quality", default="medium")
    ap.add_argument("--refine", default="8,12,16,24,32,48,64",
                    help="cells across for the refinement table ('' to skip it)")
    ap.add_argument("--only-refine", action="store_true")
    ap.add_argument("--replot", action="store_true",
                    help="redraw --plot from the table in --out without running anything")
    args = ap.parse_args()
    if args.replot:
        plot(args.plot, read_curves(args.out))
        return
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-fld-")
    header = ("| scene | reference se | single | POP | FLD 4x coarser | FLD 2x | FLD voxels | "
              "--fld-p1 off | --fld-l1 off | --fld-limiter off | FLD s (voxels) | "
              "CG iterations |")
    lines = [f"`bench/bench_fld.py BUILD --ref-seconds {args.ref_seconds:g} --size {args.size} "
             f"--quality {args.quality}` (C path)", "", header, "|---" * 12 + "|"]
    curves = []
    for case in [] if args.only_refine else CASES[1:]:
        label, sample = case[0], case[1]
        vdb, medium, view, ref = case_reference(exe, tmp, SAMPLES, case, args.size,
                                                args.ref_seconds)

        def error(method, extra):
            return baked_error(exe, vdb, ref, tmp, medium, view, method,
                               ["--quality", args.quality, *extra])

        single, se, _ = error("single", [])
        pop, _, _ = error("pop", [])
        n = VOXELS[sample]
        res = [n // 4, n // 2, n]
        errs = []
        for r in res:
            e, _, rep = error("fld", ["--fld-res", str(r)])
            errs.append(e)
            print(f"  {label}: FLD {r} cells: {e:.3f} ({rep['seconds']['fld_solve']:.1f} s)",
                  flush=True)
        seconds, iterations = rep['seconds']['fld_solve'], rep['fld']['cg_iterations']
        variants = [error("fld", ["--fld-res", str(n), flag, "off"])[0]
                    for flag in ("--fld-p1", "--fld-l1", "--fld-limiter")]
        row = (f"| {label} | {se:.4f} | {single:.3f} | {pop:.3f} | " +
               " | ".join(f"{e:.3f}" for e in errs + variants) +
               f" | {seconds:.1f} | {iterations} |")
        lines.append(row)
        print(row, flush=True)
        curves.append((label, single, pop, res, errs))
    if args.refine:
        refine(exe, tmp, args, lines)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    plot(args.plot, curves)
    print(open(args.out).read())


if __name__ == "__main__":
    main()
