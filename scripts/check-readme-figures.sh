#!/usr/bin/env bash
# Checks the figures README.md shows for the sample run against a fresh run: plays
# data/scenes/bunny-drop.toml for 480 steps (out/bunny-5k.h5: run scripts/bake-sample.sh
# first) and compares every line of its summary that does not depend on the machine's
# speed (energy, momentum, fracture, contacts, response, solver, exact re-solves, the
# step count) with the block under README.md's "sample-output" marker. Wall times, the
# per-phase timings and the checks' cost are left out. The figures hold on any x86-64
# machine with OpenBLAS held to its Prescott kernels (docs/reproducibility.md), which
# this script sets even where OPENBLAS_CORETYPE says otherwise. Exit 0 when they match; 1 with a diff when they do not.
#   usage: scripts/check-readme-figures.sh [PLAYER]   (default: the release build's)
set -euo pipefail
cd "$(dirname "$0")/.."
player=${1:-}
if [[ -z $player ]]; then
  for p in build/release/player/fissure-player build/release/player/app/fissure-player; do
    [[ -x $p ]] && { player=$p; break; }
  done
fi
[[ -n $player && -x $player ]] || { echo "error: no fissure-player found under build/release/player" >&2; echo "hint: bash scripts/build.sh release, or pass the player's path" >&2; exit 1; }
[[ -f out/bunny-5k.h5 ]] || { echo "error: out/bunny-5k.h5 is missing" >&2; echo "hint: run scripts/bake-sample.sh first" >&2; exit 1; }
# Always Prescott, whatever the environment says: the README's figures are those kernels'.
export OPENBLAS_CORETYPE=Prescott
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The machine-independent lines: the first without its wall time; no phase rows, no checks.
stable() {
  sed -E -e '/^phase +mean ms/d' -e '/^[a-z]+( +[0-9]+\.[0-9]+){2,3}$/d' -e '/^checks /d' \
    -e 's/ in [0-9.]+ s wall$/ in … s wall/'
}
awk '/<!-- sample-output/ {found = 1; next} found && /^```$/ {if (open) exit; open = 1; next} open' README.md \
  | stable > "$work/readme.txt"
[[ -s $work/readme.txt ]] || { echo "error: README.md has no block under a <!-- sample-output --> marker" >&2; exit 1; }
"$player" -q run data/scenes/bunny-drop.toml --steps 480 --no-render | stable > "$work/run.txt"
if diff -u --label README.md --label "$player run" "$work/readme.txt" "$work/run.txt"; then
  echo "README.md's sample figures match the run ($(wc -l < "$work/run.txt") lines compared)"
else
  echo "error: README.md's sample figures differ from the run (above)" >&2
  echo "hint: if the change of figures is intended, paste the run's summary into README.md (scripts/bake-sample.sh prints it)" >&2
  exit 1
fi
