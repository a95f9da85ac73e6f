#!/usr/bin/python3
"""What a lit VDB buys, side by side in one run on a real cloud (shared/data's Disney cloud at
sixteenth resolution, mean optical depth 10, albedo 0.98, g 0.8, a side sun and a sky, the
default bake: svd at low):

A. One 320x240 picture: `render --mode baked` from the stored depths against `--relight`
   (light grids swept per render) and the Monte-Carlo reference at the spp that reaches the
   baked render's error against a long reference: time, peak memory (max RSS) and error.
B. An orbit of N frames: one bake + N renders from the grids, against N relit renders and N
   reference renders at that spp.
C. The file: bytes per active voxel with --store lights and --store none, at low and medium.
D. The viewer (under xvfb-run, when vdbscatter-view and a display exist): time to the first
   frame (open + first frame) against one frame's time.

usage: python3 bench/bench_lit.py BUILD_DIR [--frames 24] [--out bench/lit.md]"""
import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.environ.get("VDBSCATTER_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
SIZE = "320x240"
SCENE = ["--density-scale", "auto:10", "--albedo", "0.98", "--g", "0.8", "--sun", "1,-0.4,0.3:3,2.9,2.7",
         "--env", "0.25,0.32,0.45"]


def run(cmd):
    """(stdout, wall seconds) of one command; exits on failure."""
    start = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {p.stderr}")
    return p.stdout, time.monotonic() - start


def peak_mib(cmd):
    """Peak RSS (MiB) of a command, through GNU time."""
    p = subprocess.run(["/usr/bin/time", "-f", "%M", *cmd], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {p.stderr}")
    return int(p.stderr.strip().splitlines()[-1]) / 1024.0


def relrmse(exe, a, b):
    import json
    out, _ = run([exe, "compare", a, b, "--json"])
    return json.loads(out)["relrmse"]


def orbit_camera(k, frames, box):
    """Frame k of an orbit around the volume's world box, slightly from above."""
    lo, hi = box
    c = [(a + b) / 2 for a, b in zip(lo, hi)]
    radius = 1.4 * max(b - a for a, b in zip(lo, hi))
    a = 2.0 * math.pi * k / frames
    p = (c[0] + radius * math.sin(a), c[1] + 0.25 * radius, c[2] + radius * math.cos(a))
    return f"{p[0]:.3f},{p[1]:.3f},{p[2]:.3f}:{c[0]:.3f},{c[1]:.3f},{c[2]:.3f}:35"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--truth-seconds", type=float, default=120.0)
    ap.add_argument("--out", default=os.path.join(HERE, "lit.md"))
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    view = os.path.join(args.build, "vdbscatter-view")
    vdb = os.path.join(DATA, "wdas_cloud_sixteenth.vdb")
    if not os.path.exists(vdb):
        sys.exit(f"{vdb} is missing (set VDBSCATTER_DATA_DIR)")
    import json
    tmp = tempfile.mkdtemp(prefix="bench_lit_")
    lines = ["# Lit VDBs: renders from the stored grids", "",
             f"`python3 bench/bench_lit.py BUILD` ({time.strftime('%Y-%m-%d')}), C path, "
             f"{os.cpu_count()} cores; wdas_cloud_sixteenth, mean optical depth 10, albedo 0.98, g 0.8, "
             "a side sun and a constant sky; default bake (svd, low). Times are wall seconds in one "
             "run on a shared machine.", ""]
    try:
        lit = os.path.join(tmp, "lit.vdb")
        out, bake_s = run([exe, "bake", vdb, "-o", lit, *SCENE, "--json", "-q"])
        bake = json.loads(out)
        voxels = bake["active_voxels"]
        info = json.loads(run([exe, "info", vdb, "--json"])[0])["grids"][0]
        box = (info["world_min"], info["world_max"])
        frame = ["--camera", orbit_camera(0, args.frames, box), "--size", SIZE]
        truth = os.path.join(tmp, "truth.exr")
        run([exe, "render", vdb, "-o", truth, "--mode", "reference", *SCENE, *frame,
             "--time", str(args.truth_seconds), "--seed", "99", "-q"])
        stored, relit = os.path.join(tmp, "stored.exr"), os.path.join(tmp, "relit.exr")
        _, stored_s = run([exe, "render", lit, "-o", stored, *frame, "-q"])
        _, relit_s = run([exe, "render", lit, "-o", relit, *frame, "--relight", "-q"])
        stored_mib = peak_mib([exe, "render", lit, "-o", stored, *frame, "-q"])
        relit_mib = peak_mib([exe, "render", lit, "-o", relit, *frame, "--relight", "-q"])
        e_stored, e_relit = relrmse(exe, stored, truth), relrmse(exe, relit, truth)
        e_between = relrmse(exe, stored, relit)
        picture = os.path.join(tmp, "picture.exr")  # A's picture, for the viewer's screenshot
        shutil.copyfile(stored, picture)
        spp, ref_s, e_ref = 1, 0.0, math.inf
        ref = os.path.join(tmp, "ref.exr")
        while spp <= 1 << 14:
            _, ref_s = run([exe, "render", vdb, "-o", ref, "--mode", "reference", *SCENE, *frame,
                            "--spp", str(spp), "--seed", "7", "-q"])
            e_ref = relrmse(exe, ref, truth)
            if e_ref <= e_stored:
                break
            spp *= 2
        lines += ["## A. One picture (320x240)", "",
                  f"Bake: {bake_s:.2f} s for {voxels} active voxels.", "",
                  "| render | seconds | peak MiB | error against a long reference |",
                  "|---|---|---|---|",
                  f"| baked, from the stored depths | {stored_s:.2f} | {stored_mib:.0f} | {e_stored:.4f} |",
                  f"| baked --relight (light grids swept) | {relit_s:.2f} | {relit_mib:.0f} | {e_relit:.4f} |",
                  f"| reference, {spp} spp (to that error) | {ref_s:.2f} | | {e_ref:.4f} |", "",
                  f"From the grids against --relight: relative RMSE {e_between:.2e}; "
                  f"**{relit_s / stored_s:.1f}x faster**; against the reference to the same error "
                  f"{ref_s / stored_s:.1f}x.", ""]
        # B. the orbit
        t_stored = t_relit = t_ref = 0.0
        for k in range(args.frames):
            cam = ["--camera", orbit_camera(k, args.frames, box), "--size", SIZE]
            t_stored += run([exe, "render", lit, "-o", stored, *cam, "-q"])[1]
            t_relit += run([exe, "render", lit, "-o", relit, *cam, "--relight", "-q"])[1]
            t_ref += run([exe, "render", vdb, "-o", ref, "--mode", "reference", *SCENE, *cam, "--spp",
                          str(spp), "--seed", str(k + 1), "-q"])[1]
        lines += [f"## B. An orbit of {args.frames} frames (320x240)", "",
                  "| | seconds | against one bake + renders from the grids |", "|---|---|---|",
                  f"| one bake + {args.frames} renders from the grids | {bake_s + t_stored:.1f} | 1 |",
                  f"| one bake + {args.frames} relit renders | {bake_s + t_relit:.1f} | "
                  f"{(bake_s + t_relit) / (bake_s + t_stored):.1f}x |",
                  f"| {args.frames} reference renders at {spp} spp (equal error) | {t_ref:.1f} | "
                  f"{t_ref / (bake_s + t_stored):.1f}x |", ""]
        # C. the file
        rows = []
        for quality in ("low", "medium"):
            sizes = {}
            for store in ("lights", "none"):
                f = os.path.join(tmp, f"size_{store}.vdb")
                out, _ = run([exe, "bake", vdb, "-o", f, *SCENE, "--method", "single", "--quality", quality,
                              "--store", store, "--json", "-q"])
                sizes[store] = os.path.getsize(f)
                sky = json.loads(out)["sky_directions"]
            rows.append(f"| {quality} ({sky} sky directions) | {sizes['none'] / voxels:.1f} | "
                        f"{sizes['lights'] / voxels:.1f} | {sizes['lights'] / sizes['none']:.2f}x |")
        lines += ["## C. The file on disk", "",
                  "| quality | bytes per active voxel, --store none | --store lights | ratio |",
                  "|---|---|---|---|", *rows, ""]
        # D. the viewer
        if shutil.which("xvfb-run") and os.path.exists(view):
            shot = os.path.join(tmp, "shot.exr")
            p = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x720x24", view, lit, "--screenshot",
                                shot, *frame, "--warmup-frames", "4", "--json", "-q", "--no-interleave"],
                               capture_output=True, text=True)
            if p.returncode == 0:
                v = json.loads(p.stdout.strip().splitlines()[-1])
                first = v["open_ms"] + v["first_frame_ms"]
                e_shot = relrmse(exe, shot, picture)
                lines += ["## D. The viewer", "",
                          "| open ms | first frame ms | one frame ms | to the first frame / one frame | "
                          "screenshot against render --mode baked |", "|---|---|---|---|---|",
                          f"| {v['open_ms']:.0f} | {v['first_frame_ms']:.0f} | {v['frame_ms']:.0f} | "
                          f"{first / v['frame_ms']:.1f}x | {e_shot:.4f} |", ""]
            else:
                lines += ["## D. The viewer", "", f"not run: {p.stderr.strip()[:200]}", ""]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text = "\n".join(lines)
    with open(args.out, "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
