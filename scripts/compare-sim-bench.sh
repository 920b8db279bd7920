#!/usr/bin/env bash
# Same-run comparison of two builds' physics step (BENCHMARKS.md): runs fissure_sim_bench
# from a baseline build and from this one in alternation, several rounds, and prints a
# Markdown table of the minimum and median ms/step of each, and their ratio.
#
# These machines are shared and noisy: a single run can be 1.5x off. Alternating puts
# the same load on both builds; the minimum is the least disturbed run, the median the
# typical one. Report ratios, not absolute figures, across sessions.
#
# Usage: scripts/compare-sim-bench.sh BASELINE_BENCH [--rounds N] [--threads N] [--only TEXT]
#                                     [--steps N] [--tolerance T]
#   BASELINE_BENCH  a fissure_sim_bench binary built from the baseline commit, e.g. in a
#                   worktree: git worktree add ../baseline <commit> && (cd ../baseline &&
#                   cmake --preset release && cmake --build build/release --target fissure_sim_bench)
#   --rounds N      alternations (default 5)
#   --threads N     worker threads (default 2)
#   --only TEXT     cases whose "cage, solver" contains TEXT (default "lagged": the player's solver)
#   --steps N       steps per case and run (default 200)
#   --tolerance T   conjugate gradients' relative residual (default 1e-4, the player's)
# The new side is build/release/tests/bench/fissure_sim_bench; build it first.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ $# -lt 1 ] || [ ! -x "$1" ]; then
  echo "usage: $0 BASELINE_BENCH [--rounds N] [--threads N] [--only TEXT] [--steps N] [--tolerance T]" >&2
  echo "  (BASELINE_BENCH must be an executable fissure_sim_bench)" >&2
  exit 2
fi
baseline=$1
shift
current=build/release/tests/bench/fissure_sim_bench
if [ ! -x "$current" ]; then
  echo "error: $current not found; build it first: cmake --build build/release --target fissure_sim_bench" >&2
  exit 2
fi
rounds=5
threads=2
only=lagged
steps=200
tolerance=1e-4
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --steps) steps=$2; shift 2 ;;
    --tolerance) tolerance=$2; shift 2 ;;
    *) echo "error: unknown option '$1' (see the comment at the top of $0)" >&2; exit 2 ;;
  esac
done

samples=$(mktemp)
trap 'rm -f "$samples"' EXIT
for round in $(seq "$rounds"); do
  echo "round $round/$rounds" >&2
  for side in baseline current; do
    bench=$baseline
    [ "$side" = current ] && bench=$current
    # Table rows: | cage | nodes | tets | solver | ms/step | … ; keep "cage, solver" and ms/step.
    "$bench" --steps "$steps" --threads "$threads" --tolerance "$tolerance" --only "$only" |
      awk -F'|' -v side="$side" '/^\| / && $6 ~ /[0-9]/ {
        gsub(/^ +| +$/, "", $2); gsub(/^ +| +$/, "", $5); gsub(/ /, "", $6)
        print side "\t" $2 ", " $5 " (" $4 + 0 " tets)\t" $6 }' >>"$samples"
  done
done

echo "threads: $threads, tolerance $tolerance, $steps steps per run, $rounds alternating rounds; ms/step"
echo
echo "| case | baseline min | baseline median | this min | this median | median ratio |"
echo "|---|---|---|---|---|---|"
python3 - "$samples" <<'EOF'
import statistics, sys
runs = {}
order = []
for line in open(sys.argv[1]):
    side, case, ms = line.rstrip("\n").split("\t")
    if case not in order:
        order.append(case)
    runs.setdefault((case, side), []).append(float(ms))
for case in order:
    old, new = runs.get((case, "baseline"), []), runs.get((case, "current"), [])
    if not old or not new:
        continue
    ratio = statistics.median(new) / statistics.median(old)
    print(f"| {case} | {min(old):.2f} | {statistics.median(old):.2f} | {min(new):.2f} | "
          f"{statistics.median(new):.2f} | {ratio:.2f}× |")
EOF
