#!/usr/bin/python3
"""Single-scattering bake throughput, C path against the compute shader (llvmpipe here,
a real GPU elsewhere), side by side in one run, per input and sky quality.

usage: bench/bench_single.py BUILD_DIR [--out bench/single.md]
Writes a markdown table; times are the solver stage from the bake report (load and
write excluded), ratios are measured in the same run."""
import argparse
import os
import subprocess
import tempfile

from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.join(ROOT, "..", "shared", "data")


def bake(exe, src, out, backend, extra):
    return run_json([exe, "bake", src, "-o", out, "--backend", backend, "--json", "-q", *extra])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "single.md"))
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-single-")
    cloud = os.path.join(tmp, "cloud128.vdb")
    subprocess.run([exe, "sample", "cloud", "--res", "128", "-o", cloud], check=True)
    cases = [
        ("sample cloud 128^3", cloud, ["--density-scale", "20", "--sun", "0.3,-1,0.2:3,3,3"]),
        ("wdas_cloud_sixteenth", os.path.join(DATA, "wdas_cloud_sixteenth.vdb"), ["--sun", "0.3,-1,0.2:3,3,3"]),
        ("openvdb_smoke1", os.path.join(DATA, "openvdb_smoke1.vdb"), ["--density-scale", "2", "--sun", "0.3,-1,0.2:3,3,3"]),
        ("wdas + sky, quality low (16 dirs)", os.path.join(DATA, "wdas_cloud_sixteenth.vdb"),
         ["--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--quality", "low"]),
        ("sample cloud 128^3 + sky, quality medium (64 dirs)", cloud,
         ["--density-scale", "20", "--sun", "0.3,-1,0.2", "--env", "0.2,0.3,0.5", "--quality", "medium"]),
    ]
    rows = []
    renderer = ""
    for name, src, extra in cases:
        c = bake(exe, src, os.path.join(tmp, "c.vdb"), "cpu", extra)
        g = bake(exe, src, os.path.join(tmp, "g.vdb"), "gpu", extra)
        renderer = g["renderer"]
        voxels = c["output_voxels"]
        rows.append((name, voxels, c["sky_directions"] if "--env" in extra else 0,
                     voxels / c["seconds"]["solve"] / 1e6, voxels / g["seconds"]["solve"] / 1e6,
                     g["seconds"]["solve"] / c["seconds"]["solve"], c["renderer"]))
        print(rows[-1], flush=True)
    with open(args.out, "w") as f:
        f.write("| input | output voxels | sky dirs | C Mvoxel/s | GLSL Mvoxel/s | GLSL time / C time |\n")
        f.write("|---|---|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.3f} | {r[4]:.3f} | {r[5]:.2f} |\n")
        f.write(f"\nC path: {rows[0][6]}; GLSL: {renderer}.\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
