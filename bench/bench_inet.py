#!/usr/bin/python3
"""--method inet against the Monte-Carlo reference, beside the other methods, on the cloud and
smoke samples and two real volumes (the Disney cloud, 1/16, and the USD smoke: the calibration
set's rigs, bench_calibrate.py). Per scene one `vdbscatter tradeoff` run (C path) renders the
reference once and measures pop, fld, svd and inet at --qualities; then inet over a table of
particles N and directions D (the window at its default, M^2 = N / 4), each bake rendered and
compared with that reference: relative RMSE (the reference's own noise in quadrature) and the
bake's seconds. Writes a Markdown file and a plot of the error against N per scene and D
(the plot needs matplotlib).

usage: bench/bench_inet.py BUILD_DIR [--out bench/inet.md] [--plot bench/inet.png]
       [--size 96x72] [--ref-noise 0.015] [--particles 1000,10000,100000]
       [--directions 32,64,128] [--scenes cloud,smoke,disney,usd_smoke] [--dir DIR]
       [--corner 1000000x64,10000x512]
--corner: single points outside the table (N x D), listed under it. The scenes not run keep
their sections from the existing --out file, so that a rerun of one scene updates it."""
import argparse
import glob
import os
import tempfile

from bench_calibrate import CALIBRATION
from benchlib import run_json, save_plot, timed

HERE = os.path.dirname(os.path.abspath(__file__))

# The calibration set's scenes (bench_calibrate.py), by name.
SCENES_RUN = ("cloud", "smoke", "disney", "usd_smoke")


def inet_point(exe, inp, scene, ref, size, tmp, n, d):
    lit = os.path.join(tmp, "lit.vdb")
    rep, _ = timed([exe, "bake", *inp, "--scene", scene, "-o", lit, "--backend", "cpu",
                    "--method", "inet", "--inet-particles", str(n), "--inet-directions", str(d),
                    "--json", "-q"])
    img = os.path.join(tmp, "img.exr")
    run_json([exe, "render", lit, "--scene", scene, "-o", img, "--backend", "cpu", "--size", size,
              "--json", "-q"])
    cmp = run_json([exe, "compare", img, ref, "--json"])
    return cmp["relrmse"], rep["seconds"]["solve"], rep["inet"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "inet.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "inet.png"))
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--ref-noise", default="0.015")
    ap.add_argument("--qualities", default="low,medium")
    ap.add_argument("--particles", default="1000,10000,100000")
    ap.add_argument("--directions", default="32,64,128")
    ap.add_argument("--scenes", default=",".join(SCENES_RUN))
    ap.add_argument("--corner", default="", help="extra N x D points, e.g. 1000000x64")
    ap.add_argument("--dir", default="", help="the tradeoff folders' parent (kept; a rerun "
                    "reuses the references); default a fresh temporary one")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    work = args.dir or tempfile.mkdtemp(prefix="bench-inet-")
    ns = [int(v) for v in args.particles.split(",")]
    ds = [int(v) for v in args.directions.split(",")]
    lines = [f"`bench/bench_inet.py BUILD --size {args.size} --ref-noise {args.ref_noise} "
             f"--particles {args.particles} --directions {args.directions}`: C path, this "
             "machine, one run. Relative RMSE of the picture against the scene's Monte-Carlo "
             "reference: for the methods (`vdbscatter tradeoff`) with the reference's noise "
             "removed, for the table of N and D (and the points under it) with it left in; "
             "seconds: bake + render for the methods, the solve for the table (the window at "
             "its default, M^2 = N / 4). Each scene's section is from the last run that "
             "measured it (its reference is named in it).", ""]
    curves = {}
    sections = {}  # scene: its lines, from the existing file, replaced by those run now
    if os.path.exists(args.out):
        current = None
        for line in open(args.out).read().split("\n"):
            if line.startswith("## "):
                current = line[3:].split(":")[0]
                sections[current] = []
            if current:
                sections[current].append(line)
    for name in args.scenes.split(","):
        start = len(lines)
        scene, vdb, what = CALIBRATION[name]
        if vdb and not os.path.exists(vdb):
            sections[name] = [f"## {name}: skipped ({vdb} missing)", ""]
            continue
        folder = os.path.join(work, name)
        inp = [vdb] if vdb else []  # None: the scene file names its own volume
        rep = run_json([exe, "tradeoff", *inp, "--scene", scene, "-o", folder, "--size", args.size,
                        "--methods", "pop,fld,svd,inet", "--qualities", args.qualities,
                        "--ref-noise", args.ref_noise, "--backend", "cpu", "--json", "-q"])
        ref = sorted(glob.glob(os.path.join(folder, "reference-*.exr")))[0]
        lines += [f"## {name}: {what}", "",
                  f"Reference: {rep['reference'].get('spp', '?')} spp, noise "
                  f"{rep['reference'].get('noise', float('nan')):.4f}.", "",
                  "| method | quality | error | seconds |", "|---|---|---|---|"]
        for row in rep["rows"]:
            if row["method"] == "reference":
                continue
            lines.append(f"| {row['method']} | {row['quality']} | {row['relrmse']:.4f} | "
                         f"{row['bake_s'] + row['render_s']:.3g} |")
        lines += ["", "| N \\ D | " + " | ".join(str(d) for d in ds) + " |",
                  "|---|" + "---|" * len(ds)]
        tmp = tempfile.mkdtemp(prefix="inet-", dir=work)
        for n in ns:
            cells = []
            for d in ds:
                err, secs, stats = inet_point(exe, inp, scene, ref, args.size, tmp, n, d)
                cells.append(f"{err:.4f} ({secs:.3g} s, {stats['iterations']} sweeps)")
                print(f"{name} N {n} D {d}: {err:.4f} in {secs:.3g} s", flush=True)
            lines.append(f"| {n} | " + " | ".join(cells) + " |")
        lines.append("")
        for point in filter(None, args.corner.split(",")):
            n, d = (int(v) for v in point.split("x"))
            err, secs, stats = inet_point(exe, inp, scene, ref, args.size, tmp, n, d)
            lines.append(f"- N {n}, D {d}: {err:.4f} ({secs:.3g} s, {stats['iterations']} "
                         "sweeps)")
            print(f"{name} N {n} D {d}: {err:.4f} in {secs:.3g} s", flush=True)
        if args.corner:
            lines.append("")
        sections[name] = lines[start:]
        del lines[start:]
    for name in list(SCENES_RUN) + [k for k in sections if k not in SCENES_RUN]:
        lines += sections.get(name, [])
    with open(args.out, "w") as f:
        f.write("\n".join(lines).rstrip("\n") + "\n")
    # The plot from the file's tables, so that kept sections are drawn too.
    name, ds = None, []
    for line in lines:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("## "):
            name, ds = line[3:].split(":")[0], []
        elif line.startswith("| N \\ D"):
            ds = cells[1:]
        elif ds and line.startswith("| ") and cells[0].isdigit():
            for d, cell in zip(ds, cells[1:]):
                curves.setdefault(f"{name}, D {d}", []).append((int(cells[0]),
                                                                float(cell.split()[0])))

    def draw(ax):
        for label, pts in curves.items():
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
        ax.set_xscale("log")
        ax.set_yscale("log")
    save_plot(args.plot, draw, "particles N", "image relative RMSE",
              "--method inet: error against N per scene and D")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
