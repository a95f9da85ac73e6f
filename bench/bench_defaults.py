#!/usr/bin/python3
"""The numbers behind the defaults: every bake method at --quality low (and the S1 light grids'
oversampling 2 against 1 per quality) on the cloud sample and on a real production cloud (the
Disney cloud at 1/16 resolution from the external test data, under cloud.json's sun and sky,
albedo 0.99, g 0.85, --density-scale auto:10), side by side in one run on the C path with the
Monte-Carlo reference of the same view: the methods through one `vdbscatter tradeoff` run per
scene, the oversampling A/B against that run's reference. Error = image relative RMSE against a
reference of relative noise --ref-noise; seconds = bake + one baked render.

usage: bench/bench_defaults.py BUILD_DIR [--out bench/defaults.md] [--size 160x120]
       [--ref-noise 0.01] [--data ../shared/data] [--qualities low,medium,high]"""
import argparse
import glob
import json
import os
import tempfile

from benchlib import run_json, timed

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


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
    ap.add_argument("--ref-noise", default="0.01")
    ap.add_argument("--ref-time", default="600")
    ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "data"))
    ap.add_argument("--qualities", default="low,medium,high")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-defaults-")
    view = ["--size", args.size, "--backend", "cpu"]
    lines = [f"`bench/bench_defaults.py BUILD --size {args.size} --ref-noise {args.ref_noise}` "
             "(C path, 2 cores). Every method at `low` from `vdbscatter tradeoff`; the S1 "
             "oversampling rows against the same reference. Error: image relative RMSE against "
             "the reference, its noise removed; seconds: bake + one baked render.", ""]
    for n, (title, scene) in enumerate(scenes(args.data, tmp)):
        work = os.path.join(tmp, f"scene{n}")
        rep = run_json([exe, "tradeoff", "--scene", scene, "-o", work, "--size", args.size,
                        "--qualities", "low", "--ref-noise", args.ref_noise, "--ref-time",
                        args.ref_time, "--backend", "cpu", "--json", "-q"])
        ref = glob.glob(os.path.join(work, "reference-*.exr"))[0]
        lines += [f"### {title}", "", "| method | quality | s1 oversample | bake s | render s | "
                  "total s | error |", "|---|---|---|---|---|---|---|"]
        for r in rep["rows"]:
            lines.append(f"| {r['method']} | {r['quality']} | default | {r['bake_s']:.2f} | "
                         f"{r['render_s']:.2f} | {r['bake_s'] + r['render_s']:.2f} | "
                         f"{r['relrmse']:.3f} |")
        # The oversampling knob is not a quality step: its own A/B against the same reference.
        for q in args.qualities.split(","):
            for over in ("1", "2"):
                lit = os.path.join(tmp, "lit.vdb")
                img = os.path.join(tmp, "img.exr")
                _, bake_s = timed([exe, "bake", "--scene", scene, "-o", lit, "--method", "svd",
                                   "--quality", q, "--s1-oversample", over, "--backend", "cpu",
                                   "--json", "-q"])
                _, render_s = timed([exe, "render", lit, "-o", img, *view, "--json", "-q"])
                c = run_json([exe, "compare", img, ref, "--json"])
                # The reference's noise removed, as tradeoff does.
                err = max(c["relrmse"] ** 2 - (c.get("se_b") or 0.0) ** 2, 0.0) ** 0.5
                row = (f"| svd | {q} | {over} | {bake_s:.2f} | {render_s:.2f} | "
                       f"{bake_s + render_s:.2f} | {err:.3f} |")
                lines.append(row)
                print(row, flush=True)
        for p in rep["reference"]["curve"]:
            lines.append(f"| reference | {p['spp']} spp | - | - | {p['seconds']:.2f} | "
                         f"{p['seconds']:.2f} | {p['relrmse']:.3f} |")
        ref_rep = rep["reference"]
        lines.append(f"\nreference: {ref_rep['spp']} spp, relative noise "
                     f"{ref_rep['noise']:.4f}, {ref_rep['seconds']:.0f} s\n")
    with open(args.out, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(open(args.out).read())


if __name__ == "__main__":
    main()
