#!/usr/bin/python3
"""The Fig. 10 case of POP's radial grids (bench/bench_pop_radial.c): runs the C bench, which
writes the table (bench/pop_radial.md) and the data (bench/pop_radial.csv), and plots ms along the radius, the probe with
its 2-se band and POP per radial grid, for g 0 and 0.8 (bench/pop_radial.png).

usage: bench/bench_pop_radial.py BUILD_DIR [--photons 16e6] [--radial 8,16,32,64]
       [--out bench/pop_radial.md] [--plot bench/pop_radial.png] [--replot CSV]"""
import argparse
import csv
import os
import subprocess

from benchlib import save_plot

HERE = os.path.dirname(os.path.abspath(__file__))


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows


def plot(rows, path):
    gs = sorted({float(r["g"]) for r in rows})
    columns = [k for k in rows[0] if k.startswith("pop")]

    def draw(ax):
        for gi, g in enumerate(gs):
            sel = [r for r in rows if float(r["g"]) == g]
            x = [float(r["r_over_R"]) for r in sel]
            probe = [float(r["probe"]) for r in sel]
            se = [float(r["se"]) for r in sel]
            style = "-" if gi == 0 else "--"
            ax.fill_between(x, [p - 2 * s for p, s in zip(probe, se)],
                            [p + 2 * s for p, s in zip(probe, se)], color="grey", alpha=0.3)
            ax.plot(x, probe, style, color="black", label=f"probe, g {g:g}")
            for c in columns:
                ax.plot(x, [float(r[c]) for r in sel], style, marker="o", markersize=3,
                        label=f"POP {c[3:]}^3, g {g:g}")
        ax.set_yscale("log")

    save_plot(path, draw, "r / R (distance from the light over the sphere's radius)",
              "ms (W / m^2 / sr, channel mean)",
              "POP radial grids: point light in a sphere of optical radius 2.5, albedo 1")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build", nargs="?")
    ap.add_argument("--photons", default="16e6")
    ap.add_argument("--radial", default="8,16,32,64")
    ap.add_argument("--out", default=os.path.join(HERE, "pop_radial.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "pop_radial.png"))
    ap.add_argument("--replot", default="", help="only plot from a CSV this bench wrote")
    args = ap.parse_args()
    if args.replot:
        plot(read_csv(args.replot), args.plot)
        return
    table = os.path.join(HERE, "pop_radial.csv")
    subprocess.run([os.path.join(args.build, "bench", "bench_pop_radial"), "--out", args.out,
                    "--csv", table, "--photons", args.photons, "--radial", args.radial],
                   check=True)
    plot(read_csv(table), args.plot)
    print("written", args.out, args.plot)


if __name__ == "__main__":
    main()
