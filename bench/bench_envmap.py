#!/usr/bin/python3
"""Environment maps: bake time against the number of sky directions K for the Disney
cloud lit by the test sky (light-grid S1, C path), and the Monte-Carlo reference's time to 5%
image standard error on the cloud sample lit by the test sky, with next-event estimation
toward the map (MIS with HG sampling) and with HG sampling alone. Side by side in one run.

usage: bench/bench_envmap.py BUILD_DIR [--out bench/envmap.md] [--ks 16,64,256]"""
import argparse
import os
import subprocess
import tempfile
import time

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.join(ROOT, "..", "shared", "data")
SAMPLES = os.path.join(ROOT, "samples")


def reference(exe, out, spp, nee):
    cmd = [exe, "render", os.path.join(SAMPLES, "cloud.vdb"), "-o", out, "--mode", "reference",
           "--density-scale", "20", "--albedo", "0.99", "--g", "0.85",
           "--env", os.path.join(SAMPLES, "sky.exr"), "--size", "64x48", "--spp", str(spp),
           "--env-nee", nee, "-q"]
    start = time.monotonic()
    subprocess.run(cmd, check=True)
    return time.monotonic() - start


def time_to(exe, tmp, nee, target):
    """Doubles spp until the image standard error is at most target; returns (spp, seconds)."""
    spp = 16
    while True:
        out = os.path.join(tmp, f"ref_{nee}.exr")
        seconds = reference(exe, out, spp, nee)
        se = run_json([exe, "compare", out, out, "--json"])["se_a"]
        if se <= target or spp >= 1 << 16:
            return spp, seconds, se
        spp *= 2


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "envmap.md"))
    ap.add_argument("--ks", default="16,64,256")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-envmap-")
    lines = ["| wdas_cloud_sixteenth at 0.2, test sky | K | bake solve s | s per direction |",
             "|---|---|---|---|"]
    wdas = os.path.join(DATA, "wdas_cloud_sixteenth.vdb")
    for k in [int(x) for x in args.ks.split(",")]:
        rep = run_json([exe, "bake", wdas, "-o", os.path.join(tmp, "w.vdb"), "--backend", "cpu",
                        "--density-scale", "0.2", "--env", os.path.join(SAMPLES, "sky.exr"),
                        "--sky-directions", str(k), "--json", "-q"])
        s = rep["seconds"]["solve"]
        row = f"| grid S1 | {k} | {s:.2f} | {s / k:.3f} |"
        lines.append(row)
        print(row, flush=True)
    lines += ["", "| reference, samples/cloud.vdb under the test sky, 64x48, all orders | spp to 5% "
              "| seconds | image standard error |", "|---|---|---|---|"]
    for nee in ["on", "off"]:
        spp, seconds, se = time_to(exe, tmp, nee, 0.05)
        row = (f"| {'map NEE + MIS with HG' if nee == 'on' else 'HG sampling alone'} | {spp} | "
               f"{seconds:.2f} | {se:.4f} |")
        lines.append(row)
        print(row, flush=True)
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
