#!/usr/bin/python3
"""POP part 2: point lights and the camera's importance, side by side in one run.

A. A point light inside the smoke sample (0,-0.5,0, intensity 2; density 10, albedo 0.99,
   g 0.3): per quality, the bake's solve seconds and POP's stages on the C path and on the
   shader path (--backend gpu: Mesa llvmpipe here), the largest difference between the two
   bakes' ms, and the image error against the Monte-Carlo reference (C path bake, rendered in
   baked mode), beside the single-scattering bake's.
B. The cloud under the bundled sky map (samples/cloud_sky.json, its camera) with few POP sky
   ordinates: the image error against the reference for that camera with and without
   --pop-importance, and the importance grid's cost beside the ordinates' propagation.

usage: bench/bench_pop_point.py BUILD_DIR [--out bench/pop_point.md] [--qualities low,...]
       [--ordinates 4,8,16] [--converged 256] [--ref-seconds 60] [--size 96x128] [--no-gpu]
       [--sections A,B]"""
import argparse
import os
import tempfile

from benchlib import run_json, timed

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")

REVERSE = "1.9,0.6,4:0,0,0:35"
SMOKE = ["--density-scale", "10", "--albedo", "0.99", "--g", "0.3", "--point", "0,-0.5,0:2,2,2"]


def image_error(exe, lit, ref, tmp, view):
    img = os.path.join(tmp, "img.exr")
    run_json([exe, "render", lit, "-o", img, "--backend", "cpu", *view, "--json", "-q"])
    cmp = run_json([exe, "compare", img, ref, "--json"])
    return cmp["relrmse"], cmp.get("se_b", 0.0)


def ms_values(path):
    import pyopenvdb as vdb
    return {tuple(i.min): i.value for i in vdb.read(path, "ms").citerOnValues()}


def section_point(exe, tmp, args, lines):
    src = os.path.join(SAMPLES, "smoke.vdb")
    view = ["--size", args.size, "--camera", "0,0,4.5:0,0,0:35"]
    ref = os.path.join(tmp, "ref_smoke.exr")
    run_json([exe, "render", src, "-o", ref, "--mode", "reference", "--time",
              str(args.ref_seconds), *SMOKE, *view, "--json", "-q"])
    lit = os.path.join(tmp, "single.vdb")
    run_json([exe, "bake", src, "-o", lit, "--backend", "cpu", *SMOKE, "--json", "-q"])
    single, se = image_error(exe, lit, ref, tmp, view)
    lines += ["## A. A point light inside the smoke sample", "",
              f"Reference se {se:.4f}; the single-scattering bake's image error {single:.3f}. "
              "Seconds are the bake's solve (S1 + POP) and POP's radial propagation, C path "
              "and shader side by side; \"C vs shader\" is the largest |ms_C - ms_shader| "
              "over the largest ms.", "",
              "| quality | radial grid | image rel RMSE (C) | solve s C | solve s shader | "
              "shader / C | propagate s C | propagate s shader | C vs shader |",
              "|---|---|---|---|---|---|---|---|---|"]
    for q in args.qualities.split(","):
        lit_c = os.path.join(tmp, f"pop_{q}_c.vdb")
        rep_c, _ = timed([exe, "bake", src, "-o", lit_c, "--backend", "cpu", "--method", "pop",
                          "--quality", q, *SMOKE, "--json", "-q"])
        err, _ = image_error(exe, lit_c, ref, tmp, view)
        row = [q, f"{rep_c['pop']['radial']}^3", f"{err:.3f}",
               f"{rep_c['seconds']['solve']:.2f}"]
        if args.no_gpu:
            row += ["-", "-", f"{rep_c['seconds']['pop_propagate']:.3f}", "-", "-"]
        else:
            lit_g = os.path.join(tmp, f"pop_{q}_g.vdb")
            rep_g, _ = timed([exe, "bake", src, "-o", lit_g, "--backend", "gpu", "--method",
                              "pop", "--quality", q, *SMOKE, "--json", "-q"])
            a, b = ms_values(lit_c), ms_values(lit_g)
            peak = max(max(v) for v in a.values())
            diff = max(max(abs(x - y) for x, y in zip(a[k], b[k])) for k in a)
            row += [f"{rep_g['seconds']['solve']:.2f}",
                    f"{rep_g['seconds']['solve'] / rep_c['seconds']['solve']:.1f}",
                    f"{rep_c['seconds']['pop_propagate']:.3f}",
                    f"{rep_g['seconds']['pop_propagate']:.3f}", f"{diff / peak:.1e}"]
        lines.append("| " + " | ".join(row) + " |")
        print(lines[-1], flush=True)


def section_importance(exe, tmp, args, lines):
    scene = os.path.join(SAMPLES, "cloud_sky.json")
    src = os.path.join(SAMPLES, "cloud.vdb")
    lines += ["", "## B. The camera's importance: the cloud under the bundled sky map", "",
              "samples/cloud_sky.json (density 20, albedo 0.99, g 0.85, sky.exr), POP at "
              "quality low with few sky ordinates, without and with --pop-importance: the "
              "image error against the reference for the camera, and against POP with "
              f"{args.converged} ordinates (the quadrature's own error, apart from POP's bias). "
              "Cameras: the scene's (the sun behind the cloud) and the opposite one "
              f"({REVERSE}, the sun behind the camera). Seconds: POP's ordinate propagation "
              "and the importance grid (propagation and projection to the 32 x 16 map), C "
              "path.", "",
              "| camera | ordinates | vs reference: without | with importance | vs POP "
              f"{args.converged}: without | with importance | propagate s | importance s | "
              "importance / propagate |",
              "|---|---|---|---|---|---|---|---|---|"]
    lit = os.path.join(tmp, "cloud_pop.vdb")
    for camera, flags in [("scene", []), ("opposite", ["--camera", REVERSE])]:
        view = ["--size", args.size_cloud, *flags]
        ref = os.path.join(tmp, "ref_cloud.exr")
        run_json([exe, "render", src, "-o", ref, "--scene", scene, "--mode", "reference",
                  "--time", str(args.ref_seconds), *view, "--json", "-q"])
        # POP's own limit of many ordinates: what the sky quadrature converges to.
        converged = os.path.join(tmp, "converged.exr")
        bake = [exe, "bake", src, "-o", lit, "--scene", scene, *flags, "--backend", "cpu",
                "--method", "pop", "--quality", "low"]
        run_json(bake + ["--pop-ordinates", str(args.converged), "--json", "-q"])
        run_json([exe, "render", lit, "-o", converged, "--backend", "cpu", *view, "--json",
                  "-q"])
        for k in args.ordinates.split(","):
            errs, quad, reps = [], [], []
            for extra in ([], ["--pop-importance"]):
                reps.append(run_json(bake + ["--pop-ordinates", k, *extra, "--json", "-q"]))
                errs.append(image_error(exe, lit, ref, tmp, view)[0])
                quad.append(image_error(exe, lit, converged, tmp, view)[0])
            prop = reps[1]["seconds"]["pop_propagate"]
            imp = reps[1]["seconds"]["pop_importance"]
            lines.append(f"| {camera} | {k} | {errs[0]:.3f} | {errs[1]:.3f} | {quad[0]:.3f} | "
                         f"{quad[1]:.3f} | {prop:.3f} | {imp:.3f} | "
                         f"{imp / max(prop, 1e-9):.1f} |")
            print(lines[-1], flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "pop_point.md"))
    ap.add_argument("--qualities", default="low,medium,high,ultra")
    ap.add_argument("--ordinates", default="4,8,16")
    ap.add_argument("--converged", type=int, default=256)
    ap.add_argument("--ref-seconds", type=float, default=60.0)
    ap.add_argument("--size", default="96x128")
    ap.add_argument("--size-cloud", default="128x96")
    ap.add_argument("--no-gpu", action="store_true")
    ap.add_argument("--sections", default="A,B")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-pop-point-")
    lines = ["# POP part 2: point lights and importance", "",
             f"`bench/bench_pop_point.py` (qualities {args.qualities}, reference "
             f"{args.ref_seconds:.0f} s per scene).", ""]
    if "A" in args.sections:
        section_point(exe, tmp, args, lines)
    if "B" in args.sections:
        section_importance(exe, tmp, args, lines)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("written", args.out)


if __name__ == "__main__":
    main()
