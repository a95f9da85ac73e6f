#!/usr/bin/python3
"""Monte-Carlo reference throughput and time-to-noise on the bundled cloud sample.

usage: bench/bench_reference.py BUILD_DIR [--out bench/reference.md] [--size 256x256]
                                [--max-bounces K] [--seed S]

Renders samples/cloud.vdb with samples/cloud.json through
`vdbscatter render --mode reference` and measures
- throughput: the least-squares slope of wall time against spp over all the runs below
  gives spp/s and paths/s (loading the volume and writing the image do not count);
- time to 5% and 2% image standard error: spp doubles until `vdbscatter compare --json`
  of the image with itself reports an image standard error (se_a: rms of the per-pixel
  standard errors over the rms of the image) at or below the target, then a run at the
  spp predicted inside the last doubling step (10% more until it is met) is timed;
- time to 1%, extrapolated from the 2% run with noise proportional to 1/sqrt(time).
Writes a markdown table."""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")


def render(exe, out, spp, args):
    cmd = [exe, "render", os.path.join(SAMPLES, "cloud.vdb"), "-o", out, "--mode", "reference",
           "--spp", str(spp), "--seed", str(args.seed), "--size", args.size,
           "--scene", os.path.join(SAMPLES, "cloud.json")]
    if args.max_bounces is not None:
        cmd += ["--max-bounces", str(args.max_bounces)]
    start = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.monotonic() - start
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()}")
    return seconds


def image_se(exe, path):
    cmd = [exe, "compare", path, path, "--json"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()}")
    metrics = json.loads(p.stdout)
    if metrics.get("se_a") is None:
        sys.exit(f"{path} carries no per-pixel standard errors (compare: se_a is null)")
    return float(metrics["se_a"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "reference.md"))
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--max-bounces", type=int, default=None)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    width, height = (int(v) for v in args.size.lower().split("x"))
    pixels = width * height
    tmp = tempfile.mkdtemp(prefix="bench-reference-")
    img = os.path.join(tmp, "ref.exr")
    load = os.getloadavg()[0]

    # Doubling spp until the smallest target is reached; every run is timed on its own.
    targets = [0.05, 0.02]
    runs = []

    def run(spp):
        seconds = render(exe, img, spp, args)
        se = image_se(exe, img)
        print(f"{spp:6d} spp: {seconds:8.2f}s  image se {100 * se:.3f}%", flush=True)
        runs.append((spp, seconds, se))
        return spp, seconds, se

    spp = 4
    while run(spp)[2] > min(targets):
        spp *= 2
    doubling = list(runs)
    reached = {}
    for target in targets:
        i = next(k for k, r in enumerate(doubling) if r[2] <= target)
        reached[target] = doubling[i]
        if i == 0:
            continue
        # Refine inside the doubling bracket: the spp predicted from the run before
        # (se proportional to 1/sqrt(spp)), then 10% steps until the target is met.
        prev_spp, _, prev_se = doubling[i - 1]
        est = int(prev_spp * (prev_se / target) ** 2 * 1.03) + 1
        while prev_spp < est < doubling[i][0]:
            r = run(est)
            if r[2] <= target:
                reached[target] = r
                break
            est = int(est * 1.1) + 1
    # Throughput: least-squares slope of wall time against spp over every run, so that
    # loading the volume and writing the image do not count.
    n = len(runs)
    mx = sum(r[0] for r in runs) / n
    my = sum(r[1] for r in runs) / n
    per_spp = sum((r[0] - mx) * (r[1] - my) for r in runs) / sum((r[0] - mx) ** 2 for r in runs)
    spp_per_s = 1.0 / per_spp
    paths_per_s = pixels / per_spp
    print(f"throughput: {spp_per_s:.2f} spp/s, {paths_per_s / 1e6:.3f} Mpaths/s", flush=True)
    spp2, sec2, se2 = reached[0.02]
    sec1 = sec2 * (se2 / 0.01) ** 2
    spp1 = spp2 * (se2 / 0.01) ** 2

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    with open(args.out, "w") as f:
        f.write(f"# Monte-Carlo reference: samples/cloud.vdb ({args.size})\n\n")
        f.write(f"Scene samples/cloud.json; seed {args.seed}; max bounces "
                f"{args.max_bounces if args.max_bounces is not None else 'CLI default'}; "
                f"{os.cpu_count()} threads on {cpu}; load average {load:.1f} at the start "
                f"(other work on the machine slows every figure).\n\n")
        f.write("| measure | value |\n|---|---|\n")
        f.write(f"| paths per second | {paths_per_s:,.0f} |\n")
        f.write(f"| spp per second | {spp_per_s:.2f} |\n")
        for target in targets:
            s, sec, se = reached[target]
            f.write(f"| time to {100 * target:g}% image se (measured) | {sec:.1f} s "
                    f"({s} spp, se {100 * se:.2f}%) |\n")
        f.write(f"| time to 1% image se (extrapolated from the 2% run) | {sec1:.0f} s "
                f"(~{spp1:.0f} spp) |\n")
        f.write("\nImage se = rms of the per-pixel standard errors / rms of the image "
                "(`vdbscatter compare --json`, se_a). Throughput is the least-squares slope of "
                "wall time against spp over all runs; the times to a target are "
                "whole-command wall times.\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
