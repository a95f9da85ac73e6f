#!/usr/bin/python3
"""Does `bake --method auto --tolerance E` meet E, and at what cost? For every scene that
bench/bench_calibrate.py measured (bench/tradeoff/calibration.json and validation.json), and
E in 0.3, 0.15, 0.08, 0.04: the plan (`--dry-run`), the error that plan's method and quality
measured there (bakes and renders on the C path are deterministic, so the tradeoff row is
the plan's result), whether it is within E + 2 standard errors, whether "out of reach" was
right (no method and quality measured within E), and its time against the cheapest fixed
method and quality that met E. Writes bench/tradeoff/auto.md.

usage: bench/bench_auto.py BUILD"""
import os
import sys

from benchlib import dry_run_plan, gathered_sets

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.environ.get("VDBSCATTER_DATA_DIR",
                      os.path.join(os.path.dirname(ROOT), "shared", "data"))
TOLERANCES = [0.3, 0.15, 0.08, 0.04]


def main():
    exe = os.path.join(sys.argv[1], "vdbscatter")
    lines = ["`bench/bench_auto.py BUILD`: `bake --method auto --tolerance E` on every scene "
             "bench_calibrate.py measured (96x72, references of relative noise about 0.01). "
             "met: the plan's measured error is at most E + 2 standard errors; out of reach: "
             "right when no method and quality measured within E. Time: bake + render of the "
             "plan against the cheapest fixed method and quality that met E (both measured "
             "in the calibration run, two shared cores: ratios are rough).", ""]
    summary = {"met": 0, "runs": 0, "ratio_ok": 0, "ratio_runs": 0}
    for kind, gathered in gathered_sets(HERE):
        lines += [f"## {kind.capitalize()} scenes", "",
                  "| scene | E | plan | its error | met | cheapest that met E | time ratio |",
                  "|---|---|---|---|---|---|---|"]
        for name, entry in sorted(gathered.items()):
            rows = {(r["method"], r["quality"]): r for r in entry["tradeoff"]["rows"]}
            secs = {k: r["bake_s"] + r["render_s"] for k, r in rows.items()}
            for e in TOLERANCES:
                p = dry_run_plan(exe, ROOT, DATA, entry, e)
                met = [k for k, r in rows.items() if r["relrmse"] <= e]
                cheapest = min(met, key=lambda k: secs[k]) if met else None
                ch = f"{cheapest[0]} {cheapest[1]} ({secs[cheapest]:.1f} s)" if cheapest else "none"
                summary["runs"] += 1
                if not p["reachable"]:
                    ok = cheapest is None
                    summary["met"] += ok
                    lines.append(f"| {name} | {e} | out of reach (best {p['predicted_error']:.3f}) "
                                 f"| - | {'right' if ok else 'WRONG'} | {ch} | - |")
                    continue
                key = (p["method"], p["quality"])
                if p["skipped_lights"] or key not in rows:
                    lines.append(f"| {name} | {e} | {key[0]} {key[1]} (not measured as planned) "
                                 f"| - | - | {ch} | - |")
                    continue
                r = rows[key]
                ok = r["relrmse"] <= e + 2 * r["relrmse_se"]
                summary["met"] += ok
                ratio = secs[key] / secs[cheapest] if cheapest else float("nan")
                if cheapest:
                    summary["ratio_runs"] += 1
                    summary["ratio_ok"] += ratio <= 1.5
                lines.append(f"| {name} | {e} | {key[0]} {key[1]} | {r['relrmse']:.4f} | "
                             f"{'yes' if ok else 'NO'} | {ch} | {ratio:.2f} |")
        lines.append("")
    lines.insert(2, f"Met its tolerance (or rightly said out of reach): {summary['met']} of "
                    f"{summary['runs']}; time within 1.5x of the cheapest that met E: "
                    f"{summary['ratio_ok']} of {summary['ratio_runs']}.\n")
    out = os.path.join(HERE, "tradeoff", "auto.md")
    open(out, "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
