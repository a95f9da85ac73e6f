#!/usr/bin/python3
"""vdbscatter-view frame times, side by side in one run: the viewer's frame (mean of
the frames after the first, which uploads) at 640x480 without and with interleaved sampling
(M = 2, 3, 4), against `render --mode baked` of the same picture (its light grids built once
per call, as the viewer builds them once per light position), with each frame's relative RMSE
against that render. Scenes: the bundled cloud (POP bake, quality low), the Disney cloud from
shared/data (sixteenth resolution, density 0.2, sun + 64-direction sky, POP low) and the
occluder sample (pillar, sphere, floor, fog: shadow maps, backdrop and the fog pass). One GPU row
(Mesa llvmpipe in the window's context) for the cloud. Runs under xvfb-run.

usage: xvfb-run -a -s "-screen 0 1280x720x24" python3 bench/bench_view.py BUILD_DIR"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")
DATA = os.environ.get("VDBSCATTER_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
SIZE = "640x480"
FRAMES = 4


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ, OMP_WAIT_POLICY="passive"))
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {p.stderr}")
    return p.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "view.md"))
    ap.add_argument("--no-gpu", action="store_true", help="skip the llvmpipe row")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    view = os.path.join(args.build, "vdbscatter-view")
    tmp = tempfile.mkdtemp(prefix="bench-view-")

    cases = []
    lit = os.path.join(tmp, "cloud_lit.vdb")
    run([exe, "bake", "--scene", os.path.join(SAMPLES, "cloud.json"), "--method", "pop", "--quality", "low",
         "-o", lit, "-q"])
    cases.append(("cloud sample", lit, []))
    wdas = os.path.join(tmp, "wdas_lit.vdb")
    run([exe, "bake", os.path.join(DATA, "wdas_cloud_sixteenth.vdb"), "--density-scale", "0.2", "--sun",
         "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--method", "pop", "--quality", "low", "-o", wdas, "-q"])
    cases.append(("Disney cloud (1/16)", wdas, []))
    occ = os.path.join(tmp, "occluder_lit.vdb")
    occ_scene = os.path.join(SAMPLES, "cloud_occluder.json")
    run([exe, "bake", "--scene", occ_scene, "--method", "pop", "--quality", "low", "-o", occ, "-q"])
    cases.append(("occluder sample (fog, 3 occluders)", occ, ["--scene", occ_scene]))

    rows = []
    for label, vdb, extra in cases:
        ref = os.path.join(tmp, "ref.exr")
        # The same scene as the viewer's (render ignores the occluders and the fog).
        rep = json.loads(run([exe, "render", vdb, *extra, "-o", ref, "--mode", "baked", "--backend", "cpu",
                              "--size", SIZE, "--json", "-q"]))
        render_ms = 1e3 * rep["seconds"]["render"]
        march_ms = 1e3 * rep["seconds"]["march"]
        rows.append((label, "render --mode baked (C): whole render", render_ms, render_ms, None, None))
        rows.append((label, "render --mode baked (C): its march alone", march_ms, march_ms, 1.0, None))
        settings = [("viewer, no interleave (C)", ["--no-interleave"]), ("viewer, 2x2 (C)", ["--interleave", "2"]),
                    ("viewer, 3x3 (C)", ["--interleave", "3"]), ("viewer, 4x4 (C)", ["--interleave", "4"])]
        for name, flags in settings:
            shot = os.path.join(tmp, "shot.exr")
            j = json.loads(run([view, vdb, *extra, "--screenshot", shot, "--size", SIZE, "--backend", "cpu",
                                "--warmup-frames", str(FRAMES), "--json", *flags]))
            error = None
            if not extra:  # the occluder scene's render ignores occluders and fog: no common picture
                error = json.loads(run([exe, "compare", shot, ref, "--json"]))["relrmse"]
            rows.append((label, name, j["frame_ms"], j["first_frame_ms"], march_ms / j["frame_ms"], error))
        if label == "cloud sample" and not args.no_gpu:
            shot = os.path.join(tmp, "gpu.exr")
            j = json.loads(run([view, vdb, "--screenshot", shot, "--size", SIZE, "--backend", "gpu",
                                "--warmup-frames", "2", "--json", "--interleave", "2"]))
            error = json.loads(run([exe, "compare", shot, ref, "--json"]))["relrmse"]
            rows.append((label, "viewer, 2x2 (" + j["renderer"].split(" (")[0] + ")", j["frame_ms"],
                         j["first_frame_ms"], march_ms / j["frame_ms"], error))

    lines = ["# vdbscatter-view frame times", "",
             f"`xvfb-run -a -s \"-screen 0 1280x720x24\" python3 bench/bench_view.py build` — {SIZE}, "
             f"quality medium (steps of 0.5 voxel, 64 sky directions), frame = mean of frames 2..{FRAMES} "
             "(the first uploads); 2 cores, one run, side by side.", "",
             "| scene | what | frame ms | first frame ms | speed vs render's march | rel. RMSE vs render |",
             "|---|---|---:|---:|---:|---:|"]
    for label, name, ms, first, speedup, error in rows:
        lines.append(f"| {label} | {name} | {ms:.0f} | {first:.0f} | "
                     f"{'' if speedup is None else f'{speedup:.2f}x'} | "
                     f"{'' if error is None else f'{error:.2e}'} |")
    lines += ["", "The whole render includes building the light grids (once per call); the viewer "
              "builds them once per light position, so a frame compares with the render's march "
              "alone (the speed column). The occluder scene's render ignores occluders and fog, "
              "so its viewer rows have no error column."]
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
