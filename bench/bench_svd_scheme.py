#!/usr/bin/python3
"""Two choices of one solver option side by side in one run, by default the SVD sweep's cell
scheme, step against weighted diamond (--svd-scheme): `vdbscatter tradeoff --methods METHOD`
at low, medium and high on each scene below with each choice, both against the same
Monte-Carlo reference (rendered once per scene, reused by the second run through tradeoff's
cache). Scenes whose volume is missing (VDBSCATTER_DATA_DIR, default ../shared/data beside
the repo) are skipped and listed. `--key svd_sky --choices collisions,boundary` (or fld_sky
with `--method fld`) compares how the sky enters (docs/design.md "The sky's uniform part")
on the sky-lit scenes: `--scenes cloud,cloud_sky,thick_cube,usd_heat,vpt_box,dragon,disney`.
`--views NAME=PX,PY,PZ:TX,TY,TZ:FOV;...` repeats every scene from those cameras (tradeoff's
`--camera`, a reference per view), for a choice that one camera could favour.

Writes a Markdown table of the relative RMSE (+- its standard error), the mean ratio to the
reference and the seconds (bake + render) per choice and quality.

usage: bench/bench_svd_scheme.py BUILD [--out bench/svd_scheme.md] [--size 96x72]
       [--ref-noise 0.02] [--scenes a,b] [--method svd] [--key svd_scheme]
       [--choices step,diamond] [--views NAME=CAMERA;...] [--qualities low,high]"""
import argparse
import json
import os
import shutil
import tempfile

from bench_calibrate import CALIBRATION, VALIDATION
from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))
# name: (scene file, input VDB or None for the scene's own): the calibration set's scenes
SCENES = {name: scene[:2] for name, scene in {**CALIBRATION, **VALIDATION}.items()}


def scene_with_choice(path, key, scheme, tmp):
    """A copy of the scene file with solver.KEY set and its volume's and env maps' paths made
    absolute, so that it reads from the temporary folder."""
    with open(path) as f:
        scene = json.load(f)
    for item in [scene.get("volume", {}), *scene.get("lights", [])]:
        if "file" in item and not os.path.isabs(item["file"]):
            item["file"] = os.path.join(os.path.dirname(path), item["file"])
    scene.setdefault("solver", {})[key] = scheme
    out = os.path.join(tmp, f"{os.path.basename(path)[:-5]}-{scheme}.json")
    with open(out, "w") as f:
        json.dump(scene, f)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "svd_scheme.md"))
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--ref-noise", default="0.02")
    ap.add_argument("--scenes", default="cloud,smoke,usd_smoke,plasma,disney")
    ap.add_argument("--method", default="svd")
    ap.add_argument("--key", default="svd_scheme")
    ap.add_argument("--choices", default="step,diamond")
    ap.add_argument("--views", default="", help="NAME=PX,PY,PZ:TX,TY,TZ:FOV;... (default: "
                    "each scene's own camera)")
    ap.add_argument("--qualities", default="", help="tradeoff's --qualities (default its own)")
    args = ap.parse_args()
    SCHEMES = args.choices.split(",")
    assert len(SCHEMES) == 2, "--choices takes two"
    exe = os.path.join(args.build, "vdbscatter")
    tmp = tempfile.mkdtemp(prefix="bench-svd-scheme-")
    views = [v.split("=", 1) for v in args.views.split(";") if v] or [("", None)]
    rows, skipped = [], []
    for name in args.scenes.split(","):
        scene_file, vdb = SCENES[name]
        if vdb and not os.path.exists(vdb):
            skipped.append(name)
            continue
        for view, camera in views:
            label = f"{name} {view}".strip()
            results = {}
            for scheme in SCHEMES:
                out = os.path.join(tmp, f"{name}-{view}-{scheme}")
                if scheme != SCHEMES[0]:
                    first = os.path.join(tmp, f"{name}-{view}-{SCHEMES[0]}")
                    shutil.copytree(first, out,
                                    ignore=shutil.ignore_patterns("images", "tradeoff*"))
                cmd = [exe, "tradeoff", *([vdb] if vdb else []), "--scene",
                       scene_with_choice(scene_file, args.key, scheme, tmp), "-o", out,
                       "--methods", args.method,
                       *(["--camera", camera] if camera else []),
                       *(["--qualities", args.qualities] if args.qualities else []),
                       "--size", args.size, "--ref-noise", args.ref_noise, "--backend", "cpu",
                       "--json", "-q"]
                rep = run_json(cmd)
                results[scheme] = {r["quality"]: r for r in rep["rows"]}
                print(f"{label} {scheme}: " + ", ".join(
                    f"{q} {r['relrmse']:.4f}" for q, r in results[scheme].items()), flush=True)
            for q in results[SCHEMES[0]]:
                rows.append((label, q, results[SCHEMES[0]][q], results[SCHEMES[1]][q]))
    shutil.rmtree(tmp, ignore_errors=True)
    with open(args.out, "w") as f:
        a, b = SCHEMES
        f.write(f"# {args.method}: {args.key} {a} against {b}\n\n")
        f.write(f"`bench/bench_svd_scheme.py` at {args.size}, references of relative noise "
                f"{args.ref_noise} (its noise removed from the errors), C path, both choices "
                "against the same reference. Error: the baked image's relative RMSE +- its "
                "standard error; ratio: the image mean over the reference's; seconds: bake + "
                "render (one machine, the schemes run one after the other)"
                + (f"; views: {args.views}" if args.views else "") + ".\n\n")
        f.write(f"| scene | quality | {a} error | {b} error | {a} ratio | {b} ratio "
                f"| {a} s | {b} s |\n|---|---|---|---|---|---|---|---|\n")
        for name, q, s, d in rows:
            f.write(f"| {name} | {q} | {s['relrmse']:.4f} +- {s['relrmse_se']:.4f} | "
                    f"{d['relrmse']:.4f} +- {d['relrmse_se']:.4f} | {s['mean_ratio']:.3f} | "
                    f"{d['mean_ratio']:.3f} | {s['bake_s'] + s['render_s']:.2f} | {d['bake_s'] + d['render_s']:.2f} |\n")
        if skipped:
            f.write(f"\nSkipped (volume missing): {', '.join(skipped)}.\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
