#!/usr/bin/python3
"""The numbers behind the defaults: every bake method at --quality low (and the S1 light grids'
oversampling 2 against 1 per quality) on the cloud sample and on a real production cloud (the
Disney cloud at 1/16 resolution from the external test data, under cloud.json's sun and sky,
albedo 0.99, g 0.85, --density-scale auto:10), side by side in one run on the C path with the
Monte-Carlo reference of the same view. Error = image relative RMSE against a --ref-seconds
reference (its own relative noise se_b in the table); seconds = bake + one baked render.

usage: bench/bench_defaults.py BUILD_DIR [--out bench/defaults.md] [--size 160x120]
       [--ref-seconds 120] [--data ../shared/data] [--qualities low,medium,high]"""
import argparse
import json
import os
import tempfile

from benchlib import run_json, timed

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
METHODS = ["single", "pop", "fld", "svd"]


def scenes(data, tmp):
    cloud = os.path.join(ROOT, "samples", "cloud.json")
    out = [("cloud sample (samples/cloud.json)", cloud)]
    wdas = os.path.join(data, "wdas_cloud_sixteenth.vdb")
    if os.path.exists(wdas):
        s = json.load(open(cloud))
        s["volume"] = {"file": wdas, "density_scale": "auto:10", "albedo": 0.99, "g": 0.85}
        s.pop("camera", None)  # the render frames the whole volume
        path = os.path.join(tmp, "wdas.json")
        json.dump(s, open(path, "w"))
        out.append(("Disney cloud 1/16 (auto:10)", path))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "defaults.md"))
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--ref-seconds", type=float, default=120.0)
    ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "data"))
    ap.add_argument("--qualities", default="low,medium,high")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-defaults-")
    view = ["--size", args.size, "--backend", "cpu"]
    lines = [f"`bench/bench_defaults.py BUILD --size {args.size} --ref-seconds "
             f"{args.ref_seconds:g}` (C path, 2 cores). Error: image relative RMSE against the "
             "reference; se_b: the reference's own relative noise; seconds: bake + one baked "
             "render.", ""]
    for title, scene in scenes(args.data, tmp):
        ref = os.path.join(tmp, "ref.exr")
        _, ref_s = timed([exe, "render", "--scene", scene, "-o", ref, "--mode", "reference",
                          "--time", str(args.ref_seconds), *view, "--json", "-q"])
        lines += [f"### {title}", "", "| method | quality | s1 oversample | bake s | render s | "
                  "total s | error | se_b |", "|---|---|---|---|---|---|---|---|"]
        runs = [(m, "low", None) for m in METHODS]
        for q in args.qualities.split(","):
            runs += [("svd", q, "1"), ("svd", q, "2")]
        for method, q, over in runs:
            lit = os.path.join(tmp, "lit.vdb")
            img = os.path.join(tmp, "img.exr")
            extra = ["--s1-oversample", over] if over else []
            _, bake_s = timed([exe, "bake", "--scene", scene, "-o", lit, "--method", method,
                               "--quality", q, *extra, "--backend", "cpu", "--json", "-q"])
            _, render_s = timed([exe, "render", lit, "-o", img, *view, "--json", "-q"])
            c = run_json([exe, "compare", img, ref, "--json"])
            row = (f"| {method} | {q} | {over or 'default'} | {bake_s:.2f} | {render_s:.2f} | "
                   f"{bake_s + render_s:.2f} | {c['relrmse']:.3f} | {c.get('se_b') or 0:.3f} |")
            lines.append(row)
            print(row, flush=True)
        for spp in (64, 256):
            out = os.path.join(tmp, "probe.exr")
            _, s = timed([exe, "render", "--scene", scene, "-o", out, "--mode", "reference",
                          "--spp", str(spp), "--seed", "11", *view, "--json", "-q"])
            err = run_json([exe, "compare", out, ref, "--json"])["relrmse"]
            row = f"| reference | {spp} spp | - | - | {s:.2f} | {s:.2f} | {err:.3f} | - |"
            lines.append(row)
            print(row, flush=True)
        lines.append(f"\nreference: {ref_s:.0f} s\n")
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
