#!/usr/bin/python3
"""POP speed, side by side in one run on the C path:
A. the cloud sample scene (samples/cloud.json: a sun and a constant sky) per quality: bake
   time, baked render time and image error against a converged reference, beside the time
   the reference itself needs to reach the same error (spp doubled from 1);
B. a 24-frame camera orbit: one bake + 24 baked renders against 24 reference renders to the
   same error (from A's reference time per frame);
C. per quality, the stage breakdown of the cloud at 64^3 / 128^3 / 256^3 under the sample's
   sun and sky, on the C path and the compute shader (--gpu; llvmpipe where there is no
   GPU), with the baked image's error against a reference of the same volume beside it;
D. the paper's configuration (64 ordinates, 20 cells, 10 iterations) on the C path.

usage: bench/bench_pop_speed.py BUILD_DIR [--out bench/pop_speed.md] [--size 1280x720]
       [--ref-seconds 120] [--orbit-quality low] [--res 64,128,256]
       [--qualities low,medium,high,ultra] [--stage-qualities 64:low,medium,high,ultra;...]
       [--gpu 64:low,medium;...] [--stage-size 160x90] [--stage-ref-seconds 30]
       [--skip ABCD] [--method pop|fld (sections A, B and C)]

With --method fld, section C also lists FLD's cells, CG iterations, operator applications
(every multigrid level) and cell updates per second of the solve (the cells those
applications updated over the fld_solve stage's time, vector work included)."""
import argparse
import math
import os
import subprocess
import tempfile

from benchlib import run_json, timed

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")
STAGES = {"pop": ["pop_sweep", "pop_seed", "pop_propagate", "pop_isotropic", "pop_merge",
                  "pop_upsample"],
          "fld": ["fld_source", "fld_solve", "fld_upsample"]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "pop_speed.md"))
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--orbit-quality", default="low")
    ap.add_argument("--stage-qualities", default="64:low,medium,high,ultra;128:low,medium,high;"
                    "256:low,medium")
    ap.add_argument("--gpu", default="64:low,medium,high;128:low,medium;256:low")
    ap.add_argument("--stage-size", default="160x90")
    ap.add_argument("--stage-ref-seconds", type=float, default=30.0)
    ap.add_argument("--skip", default="", help="sections to skip, e.g. AB")
    ap.add_argument("--method", default="pop", help="the solver of sections A, B and C")
    ap.add_argument("--ref-seconds", type=float, default=120.0)
    ap.add_argument("--qualities", default="low,medium,high,ultra")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-pop-speed-")
    scene = os.path.join(SAMPLES, "cloud.json")
    view = ["--size", args.size]
    lines = []

    # A: per quality, against the reference's time to the same error.
    per_quality = {}
    if "A" not in args.skip:
        section_a(args, exe, tmp, scene, view, lines, per_quality)
    if "B" not in args.skip and per_quality:
        section_b(args, exe, tmp, view, lines, per_quality)
    if "C" not in args.skip:
        section_c(args, exe, tmp, scene, lines)
    if "D" not in args.skip:
        section_d(exe, tmp, lines)
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(open(args.out).read())


def section_a(args, exe, tmp, scene, view, lines, per_quality):
    ref = os.path.join(tmp, "ref.exr")
    run_json([exe, "render", "--scene", scene, "-o", ref, "--mode", "reference", "--time",
              str(args.ref_seconds), *view, "--json", "-q"])
    lines += [f"A. samples/cloud.json at {args.size}, C path, --method {args.method}; converged "
              f"reference: {args.ref_seconds:.0f} s.", "",
              "| quality | bake s | render s | baked error | reference spp to that error | "
              "reference s | bake + render / reference |", "|---|---|---|---|---|---|---|"]
    for q in args.qualities.split(","):
        lit = os.path.join(tmp, f"{q}.vdb")
        img = os.path.join(tmp, f"{q}.exr")
        bake, bake_s = timed([exe, "bake", "--scene", scene, "-o", lit, "--method", args.method,
                              "--quality", q, "--backend", "cpu", "--json", "-q"])
        _, render_s = timed([exe, "render", lit, "-o", img, "--backend", "cpu", *view, "--json",
                             "-q"])
        err = run_json([exe, "compare", img, ref, "--json"])["relrmse"]
        spp, ref_s, ref_err = 1, 0.0, math.inf
        while spp <= 1 << 14:
            out = os.path.join(tmp, "probe.exr")
            _, ref_s = timed([exe, "render", "--scene", scene, "-o", out, "--mode", "reference",
                              "--spp", str(spp), "--seed", "11", *view, "--json", "-q"])
            ref_err = run_json([exe, "compare", out, ref, "--json"])["relrmse"]
            if ref_err <= err:
                break
            spp *= 2
        per_quality[q] = (bake_s, render_s, ref_s)
        row = (f"| {q} | {bake_s:.2f} | {render_s:.2f} | {err:.3f} | {spp} ({ref_err:.3f}) | "
               f"{ref_s:.2f} | {(bake_s + render_s) / ref_s:.2f} |")
        lines.append(row)
        print(row, flush=True)



def section_b(args, exe, tmp, view, lines, per_quality):
    """A 24-frame orbit at --orbit-quality."""
    q = args.orbit_quality if args.orbit_quality in per_quality else next(iter(per_quality))
    bake_s, _, ref_s = per_quality[q]
    lit = os.path.join(tmp, f"{q}.vdb")
    renders = 0.0
    for f in range(24):
        a = 2 * math.pi * f / 24
        cam = f"{4.5 * math.sin(a):.4f},0.6,{4.5 * math.cos(a):.4f}:0,0,0:35"
        _, s = timed([exe, "render", lit, "-o", os.path.join(tmp, "orbit.exr"), "--backend",
                      "cpu", "--camera", cam, *view, "--json", "-q"])
        renders += s
    lines += ["", f"B. 24-frame orbit ({q}): one bake + 24 baked renders {bake_s + renders:.1f} s; "
              f"24 reference renders to the same error {24 * ref_s:.1f} s (ratio "
              f"{(bake_s + renders) / (24 * ref_s):.2f}).", ""]
    print(lines[-2], flush=True)



def parse_plan(text):
    """"64:low,medium;128:low" -> [(64, ["low", "medium"]), (128, ["low"])]."""
    plan = []
    for part in filter(None, text.split(";")):
        n, qs = part.split(":")
        plan.append((int(n), qs.split(",")))
    return plan


def section_c(args, exe, tmp, scene, lines):
    """Stage times per size, quality and backend, the baked image's error beside them."""
    stages = STAGES[args.method]
    fld = args.method == "fld"
    what = ("default FLD (the quality's cells, limiter, first-moment source)" if fld else
            "default POP (4 cells, chord tally)")
    extra = ["cells", "CG iterations", "operator applications", "cell updates / s"] if fld else []
    lines += ["", f"C. cloud sample at N^3 under samples/cloud.json's lights (density 20, "
              f"albedo 0.99, g 0.85, a sun and a constant sky), {what}; error: "
              f"the baked render at {args.stage_size} against a {args.stage_ref_seconds:.0f} s "
              f"reference of the same volume; s1: the solve's time outside {args.method}'s "
              "stages.", "",
              "| N^3 | active voxels | quality | backend | solve s | s1 | " +
              " | ".join(stages + extra) + f" | {args.method} error | reference se |",
              "|---" * (8 + len(stages) + len(extra)) + "|"]
    gpu = dict(parse_plan(args.gpu))
    view = ["--size", args.stage_size]
    for n, qualities in parse_plan(args.stage_qualities):
        vdb = os.path.join(tmp, f"cloud{n}.vdb")
        subprocess.run([exe, "sample", "cloud", "--res", str(n), "-o", vdb, "-q"], check=True)
        ref = os.path.join(tmp, f"ref{n}.exr")
        run_json([exe, "render", vdb, "--scene", scene, "-o", ref, "--mode", "reference",
                  "--time", str(args.stage_ref_seconds), *view, "--json", "-q"])
        for q in qualities:
            for backend in ["cpu", "gpu"]:
                if backend == "gpu" and q not in gpu.get(n, []):
                    continue
                lit = os.path.join(tmp, "c.vdb")
                rep = run_json([exe, "bake", vdb, "--scene", scene, "-o", lit, "--method",
                                args.method, "--quality", q, "--backend", backend, "--json",
                                "-q"])
                img = os.path.join(tmp, "c.exr")
                run_json([exe, "render", lit, "-o", img, "--backend", "cpu", *view, "--json",
                          "-q"])
                cmp = run_json([exe, "compare", img, ref, "--json"])
                err = cmp["relrmse"]
                sec = rep["seconds"]
                s1 = sec["solve"] - sum(sec[s] for s in stages)
                cols = [f"{sec[s]:.3f}" for s in stages]
                if fld:
                    f = rep["fld"]
                    cols += [str(f["cells"]), str(f["cg_iterations"]),
                             str(f["operator_applications"]),
                             f"{f['cell_updates'] / max(sec['fld_solve'], 1e-9):.3g}"]
                row = (f"| {n} | {rep['active_voxels']} | {q} | {backend} | {sec['solve']:.2f} | "
                       f"{s1:.2f} | " + " | ".join(cols) + f" | {err:.3f} | {cmp['se_b']:.4f} |")
                lines.append(row)
                print(row, flush=True)


def section_d(exe, tmp, lines):
    """The paper's configuration: 64 ordinates of a constant sky, 20 cells, 10 iterations."""
    rep = run_json([exe, "bake", os.path.join(SAMPLES, "cloud.vdb"), "-o",
                    os.path.join(tmp, "p.vdb"), "--method", "pop", "--backend", "cpu",
                    "--density-scale", "20", "--albedo", "0.99", "--g", "0.85", "--env",
                    "0.5,0.6,0.8", "--quality", "low", "--pop-ordinates", "64", "--pop-res", "20",
                    "--pop-iterations", "10", "--json", "-q"])
    sec = rep["seconds"]
    p = rep["pop"]
    aniso = p["cells"] * min(10, p["iterations_anisotropic"])
    lines += ["", f"D. The paper's configuration (64 sky ordinates, 20 cells across, 10 "
              f"iterations; cloud sample, C path): {p['cells']} cells in {p['grids']} grids, "
              f"anisotropic propagation {sec['pop_propagate']:.3f} s ({aniso / sec['pop_propagate']:.3g} "
              f"cell updates per s; the paper: 12 ms on a 2013 GPU), then "
              f"{p['iterations_isotropic']} isotropic iterations in {sec['pop_isotropic']:.3f} s; "
              f"whole solve {sec['solve']:.2f} s (S1 with 16 sky directions included)."]
    print(lines[-1], flush=True)


if __name__ == "__main__":
    main()
