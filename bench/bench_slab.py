#!/usr/bin/python3
"""A thin slab through the solvers' grids: 300 x 10 x 300 voxels of side 1, optical thickness
1 (density scale 0.1), albedo 1, g 0.75, the sun overhead. Bakes it with svd and fld at
low / medium / high on the C path, renders the lit VDB in baked mode with an 8 x 8 camera of
2 degrees looking at the slab's centre along mu = 1 and mu = 0.5, and compares the mean with
adding-doubling's reflected radiance (bench_slab, tests/planeparallel.c), and with the radiance
a perfect solver's lit VDB renders: the discrete-ordinates field inside the slab with its multiple
scattering rebuilt from the two moments the lit VDB carries (ms, ms_l1). `before` is a build
of cubic cells (BEFORE, e.g. the main branch's vdbscatter), `after` this build with its default
cells per axis; --svd-across / --fld-across values in ACROSS add rows. Writes bench/slab.md.

usage: bench_slab.py BUILD_DIR [BEFORE_EXE] [--across N,N] [--methods svd,fld]"""
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
from exrfile import write_exr  # noqa: E402

MEDIUM = ["--density-scale", "0.1", "--albedo", "1", "--g", "0.75", "--sun", "0,-1,0:1,1,1"]
CENTRE = (149.5, 9.5, 149.5)
VIEWS = {"1": "149.5,40,149.5", "0.5": "175.91,24.75,149.5"}  # 30.5 units from the centre


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {p.stderr}")
    return p.stdout


def image_mean(exe, img, one):
    """The mean of an image whose pixels are all below 1, from compare against all ones."""
    m = json.loads(run([exe, "compare", img, one, "--json"]))
    return 1.0 - 1.001 * m["mean_rel"]


def measure(exe, slab, tmp, one, method, quality, extra):
    lit = os.path.join(tmp, "lit.vdb")
    t0 = time.time()
    run([exe, "bake", slab, "-o", lit, "--method", method, "--quality", quality, "--backend",
         "cpu", "-q", *MEDIUM, *extra])
    seconds = time.time() - t0
    out = {}
    for mu, pos in VIEWS.items():
        img = os.path.join(tmp, "img.exr")
        run([exe, "render", lit, "-o", img, "-q", "--backend", "cpu", "--size", "8x8",
             "--camera", f"{pos}:{CENTRE[0]},{CENTRE[1]},{CENTRE[2]}:2"])
        out[mu] = image_mean(exe, img, one)
    return out, seconds


def main():
    args = sys.argv[1:]
    across = []
    if "--across" in args:
        i = args.index("--across")
        across = [int(v) for v in args[i + 1].split(",")]
        del args[i:i + 2]
    methods = ["svd", "fld"]
    if "--methods" in args:
        i = args.index("--methods")
        methods = args[i + 1].split(",")
        del args[i:i + 2]
    build = args[0]
    exe = os.path.join(build, "vdbscatter")
    before = args[1] if len(args) > 1 else None
    tmp = tempfile.mkdtemp(prefix="bench-slab-")
    slab = os.path.join(tmp, "slab.vdb")
    oracles = json.loads(run([os.path.join(build, "bench", "bench_slab"), slab, "300", "10", "1",
                              "1", "0.75", *VIEWS]))
    oracle, moments = oracles["radiance"], oracles["moments"]
    one = os.path.join(tmp, "one.exr")
    write_exr(one, 8, 8, {c: [1.0] * 64 for c in "RGB"})
    rows = []
    for method in methods:
        for quality in ["low", "medium", "high"]:
            runs = []
            if before:
                runs.append(("before (cubic)", before, []))
            runs.append(("default", exe, []))
            for n in across:
                runs.append((f"--{method}-across {n}", exe, [f"--{method}-across", str(n)]))
            for label, x, extra in runs:
                r, s = measure(x, slab, tmp, one, method, quality, extra)
                rows.append((method, quality, label, r, s))
                print(method, quality, label, r, f"{s:.1f}s", flush=True)
    lines = ["# A thin slab through the solvers' grids", "",
             "`bench/bench_slab.py` (" + time.strftime("%Y-%m-%d") + "): 300 x 10 x 300 voxels,"
             " optical thickness 1, albedo 1, g 0.75, sun overhead; the lit VDB rendered in baked"
             " mode at the slab's centre (8 x 8 pixels, 2 degrees), its mean against"
             " adding-doubling's reflected radiance (single and multiple scattering: "
             f"{oracle['1']:.6f} at mu = 1, {oracle['0.5']:.6f} at mu = 0.5). \"Moments\": the same"
             " against what a perfect solver's lit VDB renders, the slab's exact field inside with"
             " its multiple scattering rebuilt from the two moments the lit VDB carries (ms and"
             f" ms_l1: {moments['1']:.6f} at mu = 1, {100 * (moments['1'] / oracle['1'] - 1):+.1f}%"
             f" from adding-doubling; {moments['0.5']:.6f} at mu = 0.5,"
             f" {100 * (moments['0.5'] / oracle['0.5'] - 1):+.1f}%). Bake seconds on the"
             " C path (2 shared cores; wall clock).", "",
             "| method | quality | grid | mu = 1 | error | moments | mu = 0.5 | error | moments "
             "| bake s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for method, quality, label, r, s in rows:
        e = {mu: r[mu] / oracle[mu] - 1.0 for mu in VIEWS}
        m = {mu: r[mu] / moments[mu] - 1.0 for mu in VIEWS}
        lines.append(f"| {method} | {quality} | {label} | {r['1']:.6f} | {100 * e['1']:+.1f}% | "
                     f"{100 * m['1']:+.1f}% | {r['0.5']:.6f} | {100 * e['0.5']:+.1f}% | "
                     f"{100 * m['0.5']:+.1f}% | {s:.1f} |")
    with open(os.path.join(HERE, "slab.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
