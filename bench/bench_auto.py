#!/usr/bin/python3
"""Does `bake --method auto --tolerance E` meet E, and at what cost? For every scene that
bench/bench_calibrate.py measured (bench/tradeoff/calibration.json and validation.json; all
of them are in the planner's table) and E in 0.3, 0.15, 0.08, 0.04, two plans (`--dry-run`):
with the table as built ("in table": the scene's own measurements are in it), and with the
scene left out of it (`--calibration-leave-out`: the planner on a scene it has not seen, as
on a user's volume). For each: the error that plan's method and quality measured there
(bakes and renders on the C path are deterministic, so the tradeoff row is the plan's
result), whether it is within E + 2 standard errors (a miss when not; out of reach, the bake
bakes the most accurate plan, and a result above E is right only when no method and quality
measured within E), and its time against the cheapest fixed method and quality that met E.
Writes
bench/tradeoff/auto.md.

usage: bench/bench_auto.py BUILD"""
import os
import sys

from benchlib import dry_run_plan, gathered_sets

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.environ.get("VDBSCATTER_DATA_DIR",
                      os.path.join(os.path.dirname(ROOT), "shared", "data"))
TOLERANCES = [0.3, 0.15, 0.08, 0.04]
WAYS = ("in table", "left out")


def judge(p, rows, secs, e, cheapest, tally):
    """(cell text, ratio text) of one plan; counts it in tally. Out of reach, the bake still
    bakes the plan of the lowest predicted error, so that plan is judged too: within E + 2
    standard errors it met E (the warning was needless); above it, the warning was right when
    no method and quality measured within E, and a miss when one did."""
    tally["runs"] += 1
    key = (p["method"], p["quality"])
    if p["skipped_lights"] or key not in rows:
        tally["unmeasured"] += 1
        return f"{key[0]} {key[1]} (not measured as planned)", "-"
    r = rows[key]
    within = r["relrmse"] <= e + 2 * r["relrmse_se"]
    ok = within or (not p["reachable"] and cheapest is None)
    tally["met"] += ok
    tally["missed"] += not ok
    tally["warned"] += not p["reachable"]
    tally["warned_needlessly"] += not p["reachable"] and cheapest is not None
    ratio = "-"
    if cheapest and within:
        x = secs[key] / secs[cheapest]
        tally["ratio_runs"] += 1
        tally["ratio_ok"] += x <= 1.5
        ratio = f"{x:.2f}"
    said = "" if p["reachable"] else "out of reach, best "
    verdict = "" if ok else " MISSED"
    if not p["reachable"] and not within and cheapest is None:
        verdict = " (none met E: right)"
    return (f"{said}{key[0]} {key[1]}: pred {p['predicted_error']:.3f}, measured "
            f"{r['relrmse']:.4f}{verdict}"), ratio


def summary_line(way, t):
    return (f"- {way}: met E (or none could and it said so) {t['met']} of {t['runs']}; missed E "
            f"{t['missed']}; said out of reach {t['warned']} times, {t['warned_needlessly']} of "
            f"them where a method met E; time within 1.5x of the cheapest that met E "
            f"{t['ratio_ok']} of {t['ratio_runs']}.")


def main():
    exe = os.path.join(sys.argv[1], "vdbscatter")
    lines = ["`bench/bench_auto.py BUILD`: `bake --method auto --tolerance E` on every scene "
             "bench_calibrate.py measured (96x72, references of relative noise about 0.01), "
             "planned with the whole table (in table) and with the scene left out of it (left "
             "out: as on a volume the planner has not seen). Met: the plan's measured error is "
             "at most E + 2 standard errors; out of reach, the bake bakes the most accurate "
             "plan, whose result above E is right only when no method and quality measured "
             "within E. Time: bake + render of the plan against the cheapest fixed "
             "method and quality that met E (both measured in the calibration run, two shared "
             "cores: ratios are rough).", ""]
    tallies = {w: dict.fromkeys(("met", "runs", "missed", "warned", "warned_needlessly",
                                 "unmeasured", "ratio_ok", "ratio_runs"), 0) for w in WAYS}
    for kind, gathered in gathered_sets(HERE):
        lines += [f"## {kind.capitalize()} scenes", "",
                  "| scene | E | plan, in table | ratio | plan, left out | ratio | "
                  "cheapest that met E |", "|---|---|---|---|---|---|---|"]
        for name, entry in sorted(gathered.items()):
            rows = {(r["method"], r["quality"]): r for r in entry["tradeoff"]["rows"]}
            secs = {k: r["bake_s"] + r["render_s"] for k, r in rows.items()}
            for e in TOLERANCES:
                met = [k for k, r in rows.items() if r["relrmse"] <= e]
                cheapest = min(met, key=lambda k: secs[k]) if met else None
                ch = f"{cheapest[0]} {cheapest[1]} ({secs[cheapest]:.1f} s)" if cheapest else "none"
                cells = []
                for way, leave in zip(WAYS, (None, name)):
                    p = dry_run_plan(exe, ROOT, DATA, entry, e, leave)
                    cells += judge(p, rows, secs, e, cheapest, tallies[way])
                lines.append(f"| {name} | {e} | " + " | ".join(cells) + f" | {ch} |")
        lines.append("")
    lines[2:2] = [summary_line(w, tallies[w]) for w in WAYS] + [""]
    out = os.path.join(HERE, "tradeoff", "auto.md")
    open(out, "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
