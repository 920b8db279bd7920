#!/usr/bin/env python3
"""Regenerates Fissure's speed/accuracy trade-study: runs the sweeps, writes their CSV
files and PNG plots into one folder. docs/tradeoffs.md shows the plots and says what to
pick.

  python3 pipelines/tradeoffs/tradeoffs.py                 # everything, into docs/tradeoffs/ (~3.5 min on 2 cores)
  python3 pipelines/tradeoffs/tradeoffs.py --quick         # CI's reduced sweep, into out/tradeoffs-quick/
  python3 pipelines/tradeoffs/tradeoffs.py --only solver   # one sweep; the other files are kept
  python3 pipelines/tradeoffs/tradeoffs.py --plots-only    # re-plot the CSV files already there

Sweeps: bake (wall resolution, bake-side sphere radius), draw (cage tets and triangles
against replication, step and draw time), solver (dt, CG tolerance, exact against warped
stiffness), contacts (sphere radius in the player against the exact every-vertex mode),
cage-method (hand-made cages against `fissure-bake cage --method lattice|wrap`), debris
(the contact response's sequential-impulse sweeps on the shattered bunny), rigid (large
fragments at rest answered as rigid bodies against all deformable).

Needs a release build (scripts/build.sh release), matplotlib (python3-matplotlib) and
h5dump (hdf5-tools): scripts/install-deps.sh installs both.

Each sweep runs in a staging folder inside the output folder; the files of every sweep
replace the old ones together, once all have succeeded, and the plots are redrawn from
them: a failed or interrupted run leaves the last good CSV files and plots (and a failed
sweep's log as SWEEP.failed.log). run.json records the commit, the machine's core count
and each sweep's wall time.
"""

import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import sweeps  # noqa: E402  (after the path holds this folder)

REPO = Path(__file__).resolve().parents[2]


def parse_arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Run Fissure's speed/accuracy sweeps and plot them (CSV and PNG files).",
        epilog="docs/tradeoffs.md explains each plot and what to pick.")
    parser.add_argument("--quick", action="store_true",
                        help="the reduced sweep CI runs (2-3 points per knob, small images; ~30 s)")
    parser.add_argument("--out", type=Path,
                        help="output folder (default: docs/tradeoffs, or out/tradeoffs-quick with --quick)")
    parser.add_argument("--build", type=Path, default=REPO / "build" / "release",
                        help="build folder holding the benchmarks and the CLIs (default: build/release)")
    parser.add_argument("--only", default=",".join(sweeps.SWEEPS),
                        help=f"comma-separated sweeps to run (default: all of {','.join(sweeps.SWEEPS)})")
    parser.add_argument("--plots-only", action="store_true", help="run nothing; re-plot the CSV files in --out")
    args = parser.parse_args()
    if args.out is None:
        args.out = REPO / ("out/tradeoffs-quick" if args.quick else "docs/tradeoffs")
    args.only = [s for s in args.only.split(",") if s]
    unknown = [s for s in args.only if s not in sweeps.SWEEPS]
    if unknown:
        parser.error(f"--only: unknown sweep {', '.join(unknown)} (sweeps: {', '.join(sweeps.SWEEPS)})")
    return args


def commit() -> str:
    """The commit measured, marked when the tree had changes."""
    def git(*a):
        return subprocess.run(["git", "-C", str(REPO), *a], capture_output=True, text=True).stdout.strip()
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + ("+changes" if git("status", "--porcelain", "--untracked-files=no") else "")


def publish(staging: Path, out: Path, names) -> None:
    """Moves the finished files into `out`, each replacing its old version in one rename."""
    for name in names:
        os.replace(staging / name, out / name)


def record(out: Path, finished: dict, quick: bool, measured: str) -> None:
    """Adds each finished sweep's run to out/run.json (what produced the files there)."""
    path = out / "run.json"
    runs = json.loads(path.read_text()) if path.is_file() else {}
    for sweep, seconds in finished.items():
        runs[sweep] = {"commit": measured, "date": datetime.date.today().isoformat(), "quick": quick,
                       "cores": os.cpu_count(), "wall_seconds": round(seconds, 1)}
    with tempfile.NamedTemporaryFile("w", dir=out, suffix=".json.tmp", delete=False) as f:
        json.dump(runs, f, indent=2, sort_keys=True)
        f.write("\n")
    os.chmod(f.name, 0o644)  # a temporary file is private; this one is documentation
    os.replace(f.name, path)


def run_one(tools: sweeps.Tools, sweep: str, quick: bool, out: Path, staging: Path) -> float:
    """Runs `sweep` into `staging`; its wall seconds. On failure its log is kept as
    out/SWEEP.failed.log and the SweepError says so."""
    start = time.monotonic()
    try:
        sweeps.run_sweep(tools, sweep, quick, staging)
        absent = [name for name in sweeps.OUTPUTS[sweep] if not (staging / name).is_file()]
        if absent:  # e.g. a benchmark built before it knew --csv, which ignored it
            raise sweeps.SweepError(f"it wrote no {', '.join(absent)}; rebuild the benchmarks")
    except sweeps.SweepError as e:
        kept = out / f"{sweep}.failed.log"
        if (staging / f"{sweep}.log").is_file():
            shutil.copy(staging / f"{sweep}.log", kept)
        raise sweeps.SweepError(f"the {sweep} sweep failed: {e}; its log: {kept}") from e
    return time.monotonic() - start


def run_sweeps(args, tools: sweeps.Tools) -> None:
    """Runs every sweep asked for, then publishes all their files together: a run that
    fails anywhere changes nothing in the output folder but the failed sweep's log."""
    for sweep in args.only:
        missing = tools.missing(sweep)
        if missing:
            raise sweeps.SweepError(f"{sweep}: {missing[0]}; build or install it first "
                                    "(FISSURE_SKIP_INSTALL=1 bash scripts/build.sh release; scripts/install-deps.sh)")
    measured = commit()  # before any file of the output folder (perhaps tracked) changes
    staged, finished = {}, {}
    try:
        for i, sweep in enumerate(args.only, 1):
            print(f"[{i}/{len(args.only)}] {sweep}", flush=True)
            staged[sweep] = Path(tempfile.mkdtemp(prefix=f".staging-{sweep}-", dir=args.out))
            finished[sweep] = run_one(tools, sweep, args.quick, args.out, staged[sweep])
            print(f"      done in {finished[sweep]:.0f} s", flush=True)
        for sweep, staging in staged.items():
            publish(staging, args.out, sweeps.OUTPUTS[sweep])
            (args.out / f"{sweep}.failed.log").unlink(missing_ok=True)
        record(args.out, finished, args.quick, measured)
    finally:
        for staging in staged.values():
            shutil.rmtree(staging, ignore_errors=True)


def plot(out: Path) -> None:
    import plots  # matplotlib is only needed from here on

    staging = Path(tempfile.mkdtemp(prefix=".staging-plots-", dir=out))
    try:
        written = plots.plot_all(out, staging)
        publish(staging, out, written)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print(f"plots: {', '.join(written) or 'none (no CSV files found)'} in {out}")


# Debian's python3-matplotlib installs for Debian's interpreter; a python3 earlier on the
# PATH (pyenv, a virtual environment) does not see it.
SYSTEM_PYTHON = "/usr/bin/python3"


def ensure_matplotlib() -> None:
    """Returns when matplotlib imports; else re-runs this script under Debian's python3
    when that one has it; else exits with a hint. Checked before any sweep runs, not after
    ten minutes of them."""
    try:
        import matplotlib  # noqa: F401
        return
    except ImportError:
        pass
    if os.path.realpath(sys.executable) != os.path.realpath(SYSTEM_PYTHON) and os.path.exists(SYSTEM_PYTHON):
        probe = subprocess.run([SYSTEM_PYTHON, "-c", "import matplotlib"], capture_output=True)
        if probe.returncode == 0:
            os.execv(SYSTEM_PYTHON, [SYSTEM_PYTHON, *sys.argv])
    print("error: matplotlib is not installed for this python3\n"
          "hint: bash scripts/install-deps.sh (python3-matplotlib), or pip install matplotlib", file=sys.stderr)
    sys.exit(1)


def main() -> int:
    args = parse_arguments()
    ensure_matplotlib()
    args.out.mkdir(parents=True, exist_ok=True)
    tools = sweeps.Tools(args.build.resolve(), REPO)
    try:
        if not args.plots_only:
            run_sweeps(args, tools)
        plot(args.out)
    except sweeps.SweepError as e:
        print(f"error: {e}\nhint: the CSV files and plots in {args.out} are those of the last good run", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted; the CSV files and plots in {args.out} are those of the last good run", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
