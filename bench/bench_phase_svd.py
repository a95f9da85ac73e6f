#!/usr/bin/python3
"""The discrete HG phase matrix's factorisation error against the number of terms (the paper's
Fig. 3): `vdbscatter phase-svd --json` for g = 0.3, 0.5, 0.7, 0.9 (and 0.85) on D
directions, with and without delta-M. Writes a Markdown table (the error at a few N, and the
smallest N under 5%) and a plot of error against N.

usage: bench/bench_phase_svd.py BUILD_DIR [--directions 256] [--out bench/phase_svd.md]
       [--plot bench/phase_svd.png]"""
import argparse
import os

from benchlib import run_json, save_plot

HERE = os.path.dirname(os.path.abspath(__file__))
GS = [0.3, 0.5, 0.7, 0.85, 0.9]
TERMS = [1, 2, 4, 8, 16, 32, 64, 128]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--directions", type=int, default=256)
    ap.add_argument("--out", default=os.path.join(HERE, "phase_svd.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "phase_svd.png"))
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    d = args.directions
    terms = [n for n in TERMS if n <= d]
    lines = [f"`bench/bench_phase_svd.py` ({d} directions): relative RMSE of the N-term "
             "factorisation of the balanced phase matrix, without delta-M and with it (auto: "
             "where the quadrature's sums are off by > 1%; f and g* given).", "",
             "| g | delta-M | f | g* | " + " | ".join(f"N={n}" for n in terms) +
             " | smallest N under 5% |",
             "|---|---|---|---|" + "---|" * len(terms) + "---|"]
    curves = []
    for g in GS:
        for mode in ["off", "auto"]:
            rep = run_json([exe, "phase-svd", "--g", str(g), "--directions", str(d),
                            "--delta-m", mode, "--json"])
            rmse = [r["rmse"] for r in rep["rows"]]
            under = next((r["terms"] for r in rep["rows"] if r["rmse"] < 0.05), None)
            lines.append(f"| {g} | {mode} | {rep['delta_m_f']:.3f} | {rep['g_scaled']:.3f} | " +
                         " | ".join(f"{rmse[n - 1]:.3f}" for n in terms) + f" | {under} |")
            print(lines[-1], flush=True)
            curves.append((f"g {g}, delta-M {mode}", rmse))
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")

    def draw(ax):
        for label, rmse in curves:
            ax.plot(range(1, len(rmse) + 1), rmse, label=label,
                    linestyle="-" if "off" in label else "--")
        ax.axhline(0.05, color="grey", linewidth=0.8, linestyle=":")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_ylim(1e-4, 1.5)

    save_plot(args.plot, draw, "terms N", "relative RMSE of the factorised phase matrix",
              f"SVD-factored HG phase, {d} directions")
    print("written", args.out, args.plot)


if __name__ == "__main__":
    main()
