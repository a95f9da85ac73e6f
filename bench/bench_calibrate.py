#!/usr/bin/python3
"""The calibration set: `vdbscatter tradeoff` on each scene below (every method at low,
medium and high against a reference of relative noise --ref-noise), the scene's planner
features (`bake --method auto --dry-run --json`), all gathered into
bench/tradeoff/calibration.json, each scene's tradeoff.md / .csv / .png under
bench/tradeoff/NAME/, and a summary bench/tradeoff/README.md. The planner's table
(vdbscatter/plan_table.h) is generated from calibration.json by scripts/gen_plan_table.py.

The scenes span g -0.3 to 0.9, albedo 0.5 to 0.999 and mean optical depth 0.5 to 50, with
suns, point lights inside and outside, constant skies and an env map, on the samples and
on volumes from other tools (VDBSCATTER_DATA_DIR, default ../shared/data beside the repo;
scenes whose file is missing are skipped and listed).

usage: bench/bench_calibrate.py BUILD [--scenes a,b] [--size 96x72] [--ref-noise 0.01]
       [--ref-time 240] [--set calibration|validation] [--cache DIR] [--methods a,b]"""
import argparse
import json
import os
import shutil
import statistics
import time

from benchlib import dry_run_plan, gathered_sets, run_json

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")
SCENES = os.path.join(HERE, "tradeoff", "scenes")
DATA = os.environ.get("VDBSCATTER_DATA_DIR",
                      os.path.join(os.path.dirname(ROOT), "shared", "data"))

# name: (scene file, input VDB or None for the scene's own, what it stands for)
CALIBRATION = {
    "cloud": (os.path.join(SAMPLES, "cloud.json"), None,
              "sample cloud, sun + constant sky, g 0.85, albedo 0.99"),
    "cloud_sky": (os.path.join(SAMPLES, "cloud_sky.json"), None,
                  "sample cloud, env map only"),
    "smoke": (os.path.join(SAMPLES, "smoke.json"), None,
              "sample smoke, sun + point light, g 0.3, albedo 0.8"),
    "sphere": (os.path.join(SAMPLES, "sphere.json"), None,
               "sample sphere, sun + point light outside, g 0, albedo 0.9"),
    "thick_cube": (os.path.join(SCENES, "thick_cube.json"), os.path.join(SAMPLES, "cube.vdb"),
                   "cube at optical depth 50, sun + env map, g 0.6, albedo 0.95"),
    "disney": (os.path.join(SCENES, "disney.json"),
               os.path.join(DATA, "wdas_cloud_sixteenth.vdb"),
               "Disney cloud (1/16), depth 20, sun + sky, g 0.9, albedo 0.999"),
    "usd_smoke": (os.path.join(SCENES, "usd_smoke.json"),
                  os.path.join(DATA, "usd_smoke_000002.vdb"),
                  "USD smoke, depth 3, sun + point light inside, g 0.5, albedo 0.9"),
    "dragon": (os.path.join(SCENES, "dragon.json"),
               os.path.join(DATA, "vpt_dragon_with_xform.vdb"),
               "sparse dragon, depth 0.5, point light outside + sky, g -0.3, albedo 0.5"),
    # Between and around the scenes above, where leaving one out showed the planner's table
    # thin: the samples under other media and rigs.
    "cloud_dark": (os.path.join(SCENES, "cloud_dark.json"), os.path.join(SAMPLES, "cloud.vdb"),
                   "sample cloud, depth 8, sun only, g 0.3, albedo 0.6"),
    "smoke_sky": (os.path.join(SCENES, "smoke_sky.json"), os.path.join(SAMPLES, "smoke.vdb"),
                  "sample smoke, depth 10, sun + constant sky, g 0.7, albedo 0.97"),
    "sphere_env": (os.path.join(SCENES, "sphere_env.json"), os.path.join(SAMPLES, "sphere.vdb"),
                   "sample sphere, depth 5, env map only, g 0.85, albedo 0.99"),
    "cube_back": (os.path.join(SCENES, "cube_back.json"), os.path.join(SAMPLES, "cube.vdb"),
                  "cube, depth 5, sun + point light inside, g -0.5, albedo 0.8"),
    "smoke_thin": (os.path.join(SCENES, "smoke_thin.json"), os.path.join(SAMPLES, "smoke.vdb"),
                   "sample smoke, depth 0.5, sun + constant sky, g 0.8, albedo 0.95"),
}

# The validation set: held out of the planner's table until its error model became a
# Gaussian process; now in it too (bench/bench_auto.py leaves each scene out in turn).
VALIDATION = {
    "plasma": (os.path.join(SCENES, "plasma.json"),
               os.path.join(DATA, "plasma_blender_fluid_0001_multigrid.vdb"),
               "Blender fluid (1k voxels), depth 2, point light inside + sun, g 0.2, albedo 0.85"),
    "usd_heat": (os.path.join(SCENES, "usd_heat.json"),
                 os.path.join(DATA, "usd_densityAndHeat.vdb"),
                 "USD density (6k voxels), depth 10, sun + env map, g 0.7, albedo 0.97"),
    "vpt_box": (os.path.join(SCENES, "vpt_box.json"), os.path.join(DATA, "vpt_box.vdb"),
                "homogeneous box with tiles, depth 5, sun + sky, g -0.2, albedo 0.7"),
}


QUALITIES = ("low", "medium", "high", "ultra")
METHODS = ("single", "pop", "fld", "svd", "inet")


def write_csv(path, rep):
    """tradeoff.csv of merged rows, as `vdbscatter tradeoff` writes it (the Pareto front
    recomputed over them). Its .md and .png stay those of the last whole run."""
    rows = rep["rows"]
    secs = [r["bake_s"] + r["render_s"] for r in rows]
    with open(path, "w") as f:
        f.write("method,quality,bake_s,render_s,total_s,peak_mib,relrmse,relrmse_se,mean_ratio,"
                "pareto\n")
        for i, r in enumerate(rows):
            pareto = not any(k != i and secs[k] <= secs[i] and b["relrmse"] <= r["relrmse"] and
                             (secs[k] < secs[i] or b["relrmse"] < r["relrmse"] or k < i)
                             for k, b in enumerate(rows))
            f.write(f"{r['method']},{r['quality']},{r['bake_s']:.4f},{r['render_s']:.4f},"
                    f"{secs[i]:.4f},{r['peak_mib']:.1f},{r['relrmse']:.6g},"
                    f"{r['relrmse_se']:.3g},{r['mean_ratio']:.6g},{int(pareto)}\n")
        for p in rep["reference"]["curve"]:
            f.write(f"reference,{p['spp']}spp,0,{p['seconds']:.4f},{p['seconds']:.4f},,"
                    f"{p['relrmse']:.6g},,1,0\n")


def ladder_lines(sets):
    """The ladders on both sets: per method and step, the scenes where the step measured worse
    than the step below by more than 2 standard errors, and the median scene's gain."""
    lines = ["## Ladders", "",
             "Per method and step: scenes where quality k+1 measured worse than k by more than "
             "two standard errors (its own and the reference's, the row's `relrmse_se`), and "
             "the median over the scenes of the error's fall, k to k+1, in those standard "
             "errors (a step pays for itself above 2).", "",
             "| method | step | worse by > 2 se | median fall (se) | scenes |",
             "|---|---|---|---|---|"]
    for m in METHODS:
        for lo, hi in zip(QUALITIES, QUALITIES[1:]):
            worse, falls = [], []
            for name, e in sets:
                rows = {(r["method"], r["quality"]): r for r in e["tradeoff"]["rows"]}
                if (m, lo) not in rows or (m, hi) not in rows:
                    continue
                a, b = rows[(m, lo)], rows[(m, hi)]
                se = max(a["relrmse_se"], b["relrmse_se"], 1e-9)
                falls.append((a["relrmse"] - b["relrmse"]) / se)
                if b["relrmse"] > a["relrmse"] + 2 * se:
                    worse.append(f"{name} ({a['relrmse']:.4f} to {b['relrmse']:.4f})")
            if falls:
                lines.append(f"| {m} | {lo} to {hi} | {', '.join(worse) or 'none'} | "
                             f"{statistics.median(falls):.1f} | {len(falls)} |")
    return lines + [""]


def summary():
    """bench/tradeoff/README.md: each scene's errors per method and quality, both sets, and
    the ladders."""
    lines = ["# The calibration set and the held-out scenes", "",
             "`bench/bench_calibrate.py BUILD [--set validation]` (96x72, references to a "
             "relative noise of 0.01 within 240 s): image relative RMSE against the "
             "reference, its noise removed, per quality measured (low / medium / high). Each "
             "scene's folder has its tradeoff.md, .csv and .png; `calibration.json` and "
             "`validation.json` hold everything, and `scripts/gen_plan_table.py` compiles "
             "the calibration set (only) into the planner's table. Timings in those files "
             "come from two shared cores and are rough.", ""]
    every = []
    for kind, gathered in gathered_sets(HERE):
        lines += [f"## {kind.capitalize()}", "",
                  "| scene | what | reference spp / noise | " + " | ".join(METHODS) + " |",
                  "|---|---|---|" + "---|" * len(METHODS)]
        for name, e in sorted(gathered.items()):
            every.append((name, e))
            rows = {(r["method"], r["quality"]): r["relrmse"] for r in e["tradeoff"]["rows"]}
            ref = e["tradeoff"]["reference"]
            cells = []
            for m in METHODS:
                cells.append(" / ".join(f"{rows[(m, q)]:.3f}" for q in QUALITIES
                                        if (m, q) in rows))
            lines.append(f"| {name} | {e['what']} | {ref['spp']} / {ref['noise']:.4f} | " +
                         " | ".join(cells) + " |")
        lines.append("")
    lines += ladder_lines(every)
    open(os.path.join(HERE, "tradeoff", "README.md"), "w").write("\n".join(lines))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--set", default="calibration", choices=["calibration", "validation"])
    ap.add_argument("--scenes", default="")
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--ref-noise", default="0.01")
    ap.add_argument("--ref-time", default="240")
    ap.add_argument("--qualities", default="low,medium,high")
    # The Disney cloud at high peaks at 20 GB with single and FLD, over the default limit (75%
    # of the memory) on a 24 GB machine: the calibration takes that knowingly.
    ap.add_argument("--max-memory", default="none",
                    help="passed to tradeoff (default none: no limit)")
    ap.add_argument("--methods", default="", help="rerun only these methods (their rows "
                    "replace the gathered ones; the others are kept)")
    ap.add_argument("--summary-only", action="store_true",
                    help="rewrite bench/tradeoff/README.md from the gathered JSON")
    ap.add_argument("--out", default="", help="the gathered JSON (default "
                    "bench/tradeoff/SET.json); re-read before each write, so that runs in "
                    "parallel on other scenes add to it")
    ap.add_argument("--cache", default=os.path.join("/tmp", "vdbscatter-calibration"),
                    help="where the tradeoff folders (references, images) live between runs")
    args = ap.parse_args()
    if args.summary_only:
        summary()
        return
    exe = os.path.join(args.build, "vdbscatter")
    table = CALIBRATION if args.set == "calibration" else VALIDATION
    names = args.scenes.split(",") if args.scenes else list(table)
    out_json = args.out or os.path.join(HERE, "tradeoff", f"{args.set}.json")
    skipped = []
    for name in names:
        scene, vdb, what = table[name]
        if vdb is not None and not os.path.exists(vdb):
            skipped.append(name)
            continue
        inp = [vdb] if vdb else []
        work = os.path.join(args.cache, name)
        start = time.monotonic()
        rep = run_json([exe, "tradeoff", *inp, "--scene", scene, "-o", work, "--size", args.size,
                   "--ref-noise", args.ref_noise, "--ref-time", args.ref_time,
                   "--qualities", args.qualities, "--max-memory", args.max_memory, "--json", "-q",
                   *(["--methods", args.methods] if args.methods else [])])
        entry = {"scene": os.path.relpath(scene, ROOT),
                 "volume": os.path.basename(vdb) if vdb else None}
        features = dry_run_plan(exe, ROOT, DATA, entry, 0.1)["features"]
        keep = os.path.join(HERE, "tradeoff", name)
        os.makedirs(keep, exist_ok=True)
        gathered = json.load(open(out_json)) if os.path.exists(out_json) else {}
        if args.methods and name in gathered:
            # Keep the other methods' rows; the reference is the same (cached under its key).
            rerun = set(args.methods.split(","))
            kept = [r for r in gathered[name]["tradeoff"]["rows"] if r["method"] not in rerun]
            rep["rows"] = sorted(kept + rep["rows"], key=lambda r: (
                METHODS.index(r["method"]) if r["method"] in METHODS else len(METHODS),
                QUALITIES.index(r["quality"]) if r["quality"] in QUALITIES else len(QUALITIES)))
            write_csv(os.path.join(keep, "tradeoff.csv"), rep)
        else:
            for f in ("tradeoff.md", "tradeoff.csv", "tradeoff.png"):
                if os.path.exists(os.path.join(work, f)):
                    shutil.copy(os.path.join(work, f), keep)
        gathered[name] = {"what": what, "scene": os.path.relpath(scene, ROOT),
                          "volume": os.path.basename(vdb) if vdb else None,
                          "size": args.size, "tradeoff": rep,
                          "features": features,
                          "seconds": time.monotonic() - start}
        json.dump(gathered, open(out_json, "w"), indent=1)
        print(f"{name}: {len(rep['rows'])} runs, reference {rep['reference']['spp']} spp "
              f"noise {rep['reference']['noise']:.4f}, {time.monotonic() - start:.0f} s",
              flush=True)
    if skipped:
        print("skipped (volume missing): " + ", ".join(skipped))
    summary()


if __name__ == "__main__":
    main()
