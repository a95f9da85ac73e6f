"""Helpers shared by the bench scripts."""
import json
import os
import subprocess
import sys
import time


def run_json(cmd):
    """Runs a vdbscatter command with --json and returns its report; exits on failure."""
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {p.stderr}")
    return json.loads(p.stdout)


def baked_error(exe, vdb, ref, tmp, medium, view, method, extra):
    """Bakes `vdb` with `method` on the C path, renders it in baked mode and compares the image
    with the reference image `ref`: (relative RMSE, the reference's se, the bake report)."""
    lit = os.path.join(tmp, "lit.vdb")
    rep = run_json([exe, "bake", vdb, "-o", lit, "--backend", "cpu", "--method", method,
                    *medium, *extra, "--json", "-q"])
    img = os.path.join(tmp, "img.exr")
    run_json([exe, "render", lit, "-o", img, "--backend", "cpu", *view, "--json", "-q"])
    cmp = run_json([exe, "compare", img, ref, "--json"])
    return cmp["relrmse"], cmp["se_b"], rep


def case_reference(exe, tmp, samples, case, size, seconds):
    """A bench case (label, sample, density scale, g, lights) made ready: its volume, medium
    flags (albedo 0.99), view flags and a reference image rendered for `seconds`."""
    _, sample, scale, g, lights = case
    vdb = os.path.join(samples, sample + ".vdb")
    medium = ["--density-scale", str(scale), "--albedo", "0.99", "--g", str(g), *lights]
    view = ["--size", size]
    ref = os.path.join(tmp, "ref.exr")
    run_json([exe, "render", vdb, "-o", ref, "--mode", "reference", "--time", str(seconds),
              *medium, *view, "--json", "-q"])
    return vdb, medium, view, ref


def timed(cmd):
    """run_json and the wall seconds it took."""
    start = time.monotonic()
    rep = run_json(cmd)
    return rep, time.monotonic() - start


def save_plot(path, draw, xlabel, ylabel, title):
    """A 7x4.5 inch PNG at `path`: draw(ax) plots, then labels, a legend and the title; says
    so and writes nothing when matplotlib is missing."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: no plot")
        return
    fig, ax = plt.subplots(figsize=(7, 4.5))
    draw(ax)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def gathered_sets(here):
    """(kind, {scene: entry}) for the calibration and validation sets bench_calibrate.py
    gathered under here/tradeoff, those that exist."""
    for kind in ("calibration", "validation"):
        path = os.path.join(here, "tradeoff", f"{kind}.json")
        if os.path.exists(path):
            with open(path) as f:
                yield kind, json.load(f)


def dry_run_plan(exe, root, data, entry, tolerance, leave_out=None):
    """`bake --method auto --tolerance T --dry-run --json` of a gathered scene: its plan
    (with leave_out, as if that calibration scene were not in the planner's table)."""
    inp = []
    if entry["volume"]:
        path = os.path.join(data, entry["volume"])
        inp = [path if os.path.exists(path) else os.path.join(root, "samples", entry["volume"])]
    return run_json([exe, "bake", *inp, "--scene", os.path.join(root, entry["scene"]), "-o",
                     "/tmp/vdbscatter-dry-run.vdb", "--method", "auto", "--tolerance",
                     str(tolerance), "--dry-run", "--json", "-q",
                     *(["--calibration-leave-out", leave_out] if leave_out else [])])["plan"]
