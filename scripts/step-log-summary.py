#!/usr/bin/env python3
"""Where a run's time goes, from `fissure-player run --step-log` files.

One Markdown row per log: the mean step and its phases, then what the run pays for
its lagged factor, split by the kind of step:
  - steps with a factorization (`factor steps`): how many, and their solve and
    assembly in ms per step of the whole run. The log's count includes the energy
    guard's factorizations (its exact re-solves), whose time is in `guard`;
  - of those, the steps that split nodes: a split changes the matrix's pattern, so the
    solver must analyse and factor afresh there whatever else it does (`split floor`);
  - the other steps' median CG iterations, and their solve time per iteration (fixed
    costs per solve included), the price of not refactoring.
Then the slowest step, with its largest phase. Phases are the player's own timings
(docs/cli.md); `other` is the step less their sum (bookkeeping, arcs, the report).

  usage: scripts/step-log-summary.py LOG.csv [LOG.csv ...]
  e.g.   STEP_LOGS=logs scripts/realtime-budgets.sh && scripts/step-log-summary.py logs/*.csv
"""
import csv
import pathlib
import statistics
import sys

PHASES = ["forces_ms", "assembly_ms", "solve_ms", "fracture_ms", "collisions_ms", "guard_ms"]
NEEDED = ["step", "step_ms", "solver_iterations", "factorizations", "splits", "response_iterations"] + PHASES


def read(path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"error: {path}: cannot read: {e.strerror}")
    except (UnicodeDecodeError, csv.Error):
        sys.exit(f"error: {path}: not a --step-log file (not CSV text)")
    if not rows:
        sys.exit(f"error: {path}: no steps: empty, or not a --step-log file")
    missing = [c for c in NEEDED if c not in rows[0]]
    if missing:
        sys.exit(f"error: {path}: not a --step-log file: no column {', '.join(missing)}\n"
                 "hint: write one with `fissure-player run SCENE --step-log FILE.csv`")
    try:
        return [{k: float(row[k]) for k in NEEDED} for row in rows]
    except (TypeError, ValueError):
        sys.exit(f"error: {path}: a value is not a number (the file is cut short or edited)")


def summarize(path, name):
    steps = read(path)
    n = len(steps)
    per_step = lambda rows, cols: sum(r[c] for r in rows for c in cols) / n  # ms per step of the run
    factor_steps = [r for r in steps if r["factorizations"] > 0]
    split_factor_steps = [r for r in factor_steps if r["splits"] > 0]
    lagged = [r for r in steps if r["factorizations"] == 0 and r["solver_iterations"] > 0]
    iterations = sum(r["solver_iterations"] for r in lagged)
    worst = max(steps, key=lambda r: r["step_ms"])
    worst_phase = max(PHASES, key=lambda c: worst[c])
    step = per_step(steps, ["step_ms"])
    phases = {c: per_step(steps, [c]) for c in PHASES}
    return {
        "log": name,
        "steps": n,
        "step": step,
        "phases": phases,
        "other": step - sum(phases.values()),
        "factorizations": int(sum(r["factorizations"] for r in steps)),
        "factor_steps": len(factor_steps),
        "factor_ms": per_step(factor_steps, ["solve_ms", "assembly_ms"]),
        "split_steps": len(split_factor_steps),
        "split_floor_ms": per_step(split_factor_steps, ["solve_ms", "assembly_ms"]),
        "lagged_iterations": statistics.median(r["solver_iterations"] for r in lagged) if lagged else 0,
        "ms_per_iteration": sum(r["solve_ms"] for r in lagged) / iterations if iterations else 0.0,
        "response_iterations": int(sum(r["response_iterations"] for r in steps)),
        "worst": f"{worst['step_ms']:.0f} (step {int(worst['step'])}, {worst_phase[:-3]} {worst[worst_phase]:.0f})",
    }


def main(paths):
    usage = __doc__.split("\n\n")[-1].rstrip()
    if paths and paths[0] in ("-h", "--help"):
        print(__doc__.rstrip())
        return
    if not paths:
        print(usage, file=sys.stderr)
        sys.exit(2)
    # A row is named by its file's stem, or by its path where two stems are the same.
    stems = [pathlib.Path(p).stem for p in paths]
    names = [stem if stems.count(stem) == 1 else path for stem, path in zip(stems, paths)]
    summaries = [summarize(p, n) for p, n in zip(paths, names)]  # every file read before anything is printed
    print("| log | steps | step ms | forces + assembly | solve | fracture | collisions | guard | other "
          "| factor steps: count, ms | split floor: count, ms | lagged steps: median CG, solve ms per CG "
          "| response CG | worst step ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|---:|---|")
    for s in summaries:
        p = s["phases"]
        print(f"| {s['log']} | {s['steps']} | {s['step']:.2f} | {p['forces_ms'] + p['assembly_ms']:.2f} "
              f"| {p['solve_ms']:.2f} | {p['fracture_ms']:.2f} | {p['collisions_ms']:.2f} | {p['guard_ms']:.2f} "
              f"| {s['other']:.2f} | {s['factor_steps']} ({s['factorizations']} factorizations), {s['factor_ms']:.2f} "
              f"| {s['split_steps']}, {s['split_floor_ms']:.2f} "
              f"| {s['lagged_iterations']:.0f}, {s['ms_per_iteration']:.3f} | {s['response_iterations']} | {s['worst']} |")
    print()
    print("ms columns are per step of the whole run (a column's total ÷ steps). Factor steps: solve and assembly "
          "of the steps that factorized (the count includes the energy guard's, whose time is in guard); "
          "split floor: the same for those that also split nodes.")


if __name__ == "__main__":
    main(sys.argv[1:])
