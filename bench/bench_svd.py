#!/usr/bin/python3
"""Discrete ordinates with the SVD-factored phase (--method svd), side by side in one run:

- accuracy: on the sphere (g 0.5) and cloud (g 0.85) samples, albedo 0.99, the baked image's
  relative RMSE against a Monte-Carlo reference as D (N = D), N (D fixed) and the grid
  resolution rise, with iterations, time per iteration, time to convergence and
  cell-direction updates per second (C path);
- bar: the cloud sample at --quality high, svd against pop and fld on the same scene and
  reference (the acceptance bar: svd <= 0.2 and below both; the script exits 1 if not);
- split: POP's error on the cloud beside its difference from svd (N = D) on the same grid
  resolution and lights: the part of POP's error that is its method's bias and the part that
  is the grid's;
- speed: per iteration, N chosen for 5% factorisation error (g 0.5, and g 0.85 after delta-M)
  against N = D on the same grid, on the C path and in the shader (llvmpipe here), after
  time per iteration against D, N and the grid on the C path (run it alone: timings).

Writes a Markdown file and a plot of the error against each knob.

usage: bench/bench_svd.py BUILD_DIR [--out bench/svd.md] [--plot bench/svd.png]
       [--ref-seconds 120] [--sections accuracy,bar,split,speed]"""
import argparse
import os
import tempfile

from benchlib import run_json, save_plot

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(os.path.dirname(HERE), "samples")
SCENES = {
    "sphere": (os.path.join(SAMPLES, "sphere.json"), ["--albedo", "0.99", "--g", "0.5"],
               "64x64"),
    "cloud": (os.path.join(SAMPLES, "cloud.json"), [], "320x180"),
}


class Bench:
    def __init__(self, args):
        self.exe = os.path.join(args.build, "vdbscatter")
        self.tmp = tempfile.mkdtemp(prefix="bench-svd-")
        self.refs = {}
        self.args = args

    def reference(self, scene):
        if scene not in self.refs:
            path, medium, size = SCENES[scene]
            ref = os.path.join(self.tmp, f"ref-{scene}.exr")
            run_json([self.exe, "render", "--scene", path, *medium, "-o", ref, "--mode",
                      "reference", "--time", str(self.args.ref_seconds), "--size", size,
                      "--json", "-q"])
            self.refs[scene] = ref
        return self.refs[scene]

    def image(self, scene, method, extra, name="img"):
        """Bakes and renders the scene: (image path, bake report)."""
        path, medium, size = SCENES[scene]
        lit = os.path.join(self.tmp, name + ".vdb")
        img = os.path.join(self.tmp, name + ".exr")
        rep = run_json([self.exe, "bake", "--scene", path, *medium, "-o", lit, "--method",
                        method, *extra, "--json", "-q"])
        run_json([self.exe, "render", lit, "-o", img, "--backend", "cpu", "--size", size,
                  "--json", "-q"])
        return img, rep

    def compare(self, a, b):
        return run_json([self.exe, "compare", a, b, "--json"])["relrmse"]

    def error(self, scene, method, extra, name="img"):
        img, rep = self.image(scene, method, extra, name)
        return self.compare(img, self.reference(scene)), rep


def svd_row(label, rep, err):
    s = rep["svd"]
    t = rep["seconds"]["svd_solve"]
    per = t / max(s["iterations"], 1)
    rate = s["cell_direction_updates"] / t if t > 0 else 0.0
    return (f"| {label} | {s['directions']} | {s['terms']} | {s['resolution']} | "
            f"{s['iterations']} | {s['residual']:.1e} | {per:.3f} | {t:.2f} | "
            f"{rep['seconds']['total']:.2f} | {rate / 1e6:.2f} | {err:.4f} |")


SVD_HEADER = ["| case | D | N | res | iterations | residual | s / iteration | solve s | "
              "bake s | M cell-dir / s | error |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]


def accuracy(b, lines, curves):
    lines += ["## Accuracy against the reference", "",
              "Error: relative RMSE of the baked image (render --mode baked) against a "
              f"{b.args.ref_seconds:g} s reference; C path; residual 1e-3. Timings here are "
              "indicative only (see the speed tables, run alone).", ""]
    sweeps = [("D (N = D, res 24)", [["--svd-directions", str(d), "--svd-terms", str(d),
                                      "--svd-res", "24"] for d in (16, 32, 64, 128, 256)]),
              ("N (D 128, res 24)", [["--svd-directions", "128", "--svd-terms", str(n),
                                      "--svd-res", "24"] for n in (2, 4, 8, 16, 32, 64, 128)]),
              ("res (D 64, N = D)", [["--svd-directions", "64", "--svd-terms", "64",
                                      "--svd-res", str(r)] for r in (8, 12, 16, 24, 32, 48)])]
    for scene in ("sphere", "cloud"):
        lines += [f"### {scene}", ""] + SVD_HEADER
        for family, cases in sweeps:
            points = []
            for extra in cases:
                err, rep = b.error(scene, "svd", extra + ["--residual", "1e-3", "--backend",
                                                         "cpu"])
                row = svd_row(family.split()[0], rep, err)
                lines.append(row)
                print(row, flush=True)
                points.append(err)
            curves[f"{scene}: {family}"] = points
        lines.append("")


def bar(b, lines):
    lines += ["## The bar: cloud, g 0.85, --quality high", "",
              "| method | bake s | error |", "|---|---|---|"]
    errors = {}
    for method in ("svd", "pop", "fld"):
        err, rep = b.error("cloud", method, ["--quality", "high", "--backend", "cpu"])
        errors[method] = err
        row = f"| {method} | {rep['seconds']['total']:.2f} | {err:.4f} |"
        lines.append(row)
        print(row, flush=True)
    ok = errors["svd"] <= 0.2 and errors["svd"] < errors["pop"] and errors["svd"] < errors["fld"]
    lines += ["", f"Asserted (svd <= 0.2, below pop and fld): {'met' if ok else 'NOT MET'}.", ""]
    return ok


def split(b, lines):
    lines += ["## POP's error split (cloud)", "",
              "POP at --pop-res R beside svd (D 128, N = D) at --svd-res R, the same lights "
              "(--quality medium): e(POP) against the reference, d = POP's image against "
              "svd's (the method's bias: both see a grid of that resolution), e(svd) against "
              "the reference (what that grid itself costs).", "",
              "| R | e(POP) | d(POP, svd) | e(svd) |", "|---|---|---|---|"]
    for res in (4, 8, 16, 32):
        pop, _ = b.image("cloud", "pop", ["--pop-res", str(res), "--backend", "cpu"], "pop")
        svd, _ = b.image("cloud", "svd", ["--svd-res", str(res), "--svd-directions", "128",
                                          "--svd-terms", "128", "--residual", "1e-3",
                                          "--backend", "cpu"], "svd")
        ref = b.reference("cloud")
        row = (f"| {res} | {b.compare(pop, ref):.4f} | {b.compare(pop, svd):.4f} | "
               f"{b.compare(svd, ref):.4f} |")
        lines.append(row)
        print(row, flush=True)
    lines.append("")


def five_percent(b, g, directions):
    rows = run_json([b.exe, "phase-svd", "--g", str(g), "--directions", str(directions),
                     "--json"])["rows"]
    return next((r["terms"] for r in rows if r["rmse"] <= 0.05), directions)


def per_iteration(b, backend, extra, iterations):
    """Seconds per iteration of the transport solve alone and cell-direction updates per
    second, from a bake forced to run `iterations` iterations."""
    _, rep = b.image("cloud", "svd", extra + ["--residual", "1e-12", "--svd-iterations",
                                              str(iterations), "--backend", backend], "speed")
    s = rep["svd"]
    t = rep["seconds"]["svd_solve"]
    return t / s["iterations"], s["cell_direction_updates"] / t, s


def speed(b, lines):
    lines += ["## Time per iteration against D, N and the grid (C path)", "",
              "The cloud, 4 iterations forced (--residual 1e-12 --svd-iterations 4), seconds "
              "per iteration of the transport solve alone; nothing else running. Time to "
              "convergence is this times the iterations of the accuracy tables above.", "",
              "| knob | D | N | res | cells | s / iteration | M cell-dir / s | "
              "ns per cell-dir-term |", "|---|---|---|---|---|---|---|---|"]
    cases = ([("D", ["--svd-directions", str(d), "--svd-terms", str(d), "--svd-res", "24"])
              for d in (16, 32, 64, 128, 256)] +
             [("N", ["--svd-directions", "128", "--svd-terms", str(n), "--svd-res", "24"])
              for n in (4, 16, 64, 128)] +
             [("res", ["--svd-directions", "64", "--svd-terms", "64", "--svd-res", str(r)])
              for r in (12, 24, 48)])
    for knob, extra in cases:
        per, rate, s = per_iteration(b, "cpu", extra, 4)
        term = per / (s["cells"] * s["directions"] * s["terms"]) * 1e9
        row = (f"| {knob} | {s['directions']} | {s['terms']} | {s['resolution']} | "
               f"{s['cells']} | {per:.3f} | {rate / 1e6:.2f} | {term:.2f} |")
        lines.append(row)
        print(row, flush=True)
    lines += ["", "## Speed: factored against N = D", "",
              "The cloud at --svd-res R, 4 iterations forced; N5 = the fewest terms with "
              "factorisation RMSE <= 5% (phase-svd, delta-M as the solver uses it). Seconds "
              "per iteration of the transport solve alone, side by side in one run.", "",
              "| backend | g | D | R | N5 | s / it (N5) | s / it (N = D) | speed-up | "
              "M cell-dir / s (N5) | M cell-dir / s (N = D) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for backend, directions, res in (("cpu", 256, 16), ("gpu", 64, 12)):
        for g in (0.5, 0.85):
            n5 = five_percent(b, g, directions)
            per, rate = {}, {}
            for n in (n5, directions):
                per[n], rate[n], _ = per_iteration(
                    b, backend, ["--g", str(g), "--svd-directions", str(directions),
                                 "--svd-terms", str(n), "--svd-res", str(res)], 4)
            row = (f"| {backend} | {g} | {directions} | {res} | {n5} | {per[n5]:.3f} | "
                   f"{per[directions]:.3f} | {per[directions] / per[n5]:.2f}x | "
                   f"{rate[n5] / 1e6:.2f} | {rate[directions] / 1e6:.2f} |")
            lines.append(row)
            print(row, flush=True)
    lines.append("")


def read_curves(path):
    """{scene: knob: [(value, error)]} from the accuracy tables of a file this script wrote."""
    curves, scene = {}, None
    for line in open(path):
        if line.startswith("### "):
            scene = line[4:].strip()
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if scene and len(cells) == 11 and cells[0] in ("D", "N", "res"):
            value = {"D": cells[1], "N": cells[2], "res": cells[3]}[cells[0]]
            curves.setdefault(f"{scene}: {cells[0]}", []).append((int(value), float(cells[10])))
    return curves


def plot(path, curves):
    def draw(ax):
        for label, pts in curves.items():
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
    save_plot(path, draw, "D (N = D, res 24), N (D 128, res 24) or cells across (D 64)",
              "image relative RMSE", "--method svd: error against each knob")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "svd.md"))
    ap.add_argument("--plot", default=os.path.join(HERE, "svd.png"))
    ap.add_argument("--ref-seconds", type=float, default=120.0)
    ap.add_argument("--sections", default="accuracy,bar,split,speed")
    ap.add_argument("--replot", action="store_true",
                    help="redraw --plot from the tables in --out without running anything")
    args = ap.parse_args()
    if args.replot:
        plot(args.plot, read_curves(args.out))
        return
    b = Bench(args)
    sections = args.sections.split(",")
    lines = [f"`bench/bench_svd.py BUILD --ref-seconds {args.ref_seconds:g} --sections "
             f"{args.sections}`: samples sphere (albedo 0.99, g 0.5, 64x64) and cloud (its "
             "scene: albedo 0.99, g 0.85, a sun and a constant sky, 320x180).", ""]
    curves = {}
    ok = True
    if "accuracy" in sections:
        accuracy(b, lines, curves)
    if "bar" in sections:
        ok = bar(b, lines)
    if "split" in sections:
        split(b, lines)
    if "speed" in sections:
        speed(b, lines)
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    if curves:
        plot(args.plot, read_curves(args.out))
    print(open(args.out).read())
    if not ok:
        raise SystemExit("svd missed the bar on the cloud at --quality high")


if __name__ == "__main__":
    main()
