#!/usr/bin/env bash
# The extremes grid of issue 16 on the sample bunny (out/bunny-5k.h5: run
# scripts/bake-sample.sh first): each case is the sample scene with one value changed,
# run with --no-energy-check so it goes on to the end; prints a Markdown table of peak
# energy ÷ energy put in, fragments, splits, ms per step (mean, max) and the deepest
# sphere and render vertex in an obstacle.
#   usage: scripts/energy-grid.sh [STEPS] [TIMEOUT_S]    (defaults 240, 300)
set -euo pipefail
cd "$(dirname "$0")/.."
steps=${1:-240}
limit=${2:-300}
player=build/release/player/app/fissure-player
[[ -f out/bunny-5k.h5 ]] || { echo "error: out/bunny-5k.h5 is missing" >&2; echo "hint: run scripts/bake-sample.sh first" >&2; exit 1; }
[[ -x $player ]] || { echo "error: $player is missing" >&2; echo "hint: bash scripts/build.sh release" >&2; exit 1; }
export OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-Prescott}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sample=data/scenes/bunny-drop.toml
bundle=$(realpath out/bunny-5k.h5)

# case name | sed expression applied to the sample scene
cases=(
  "sample|"
  "resting, dt = 0.05 s|/\[\[projectile\]\]/,\$d; s/^dt = .*/dt = 0.05/"
  "resting, dt = 0.1 s|/\[\[projectile\]\]/,\$d; s/^dt = .*/dt = 0.1/"
  "resting, dt = 0.5 s|/\[\[projectile\]\]/,\$d; s/^dt = .*/dt = 0.5/"
  "resting, dt = 1 s|/\[\[projectile\]\]/,\$d; s/^dt = .*/dt = 1.0/"
  "resting, dt = 0.5 s, no fracture|/\[\[projectile\]\]/,\$d; s/^dt = .*/dt = 0.5/; s/^fracture = true/fracture = false/"
  "dt = 1e-5 s|s/^dt = .*/dt = 1e-5/"
  "E = 1e3 Pa|s/^youngs_modulus = .*/youngs_modulus = 1e3/"
  "E = 1e12 Pa, no fracture|s/^youngs_modulus = .*/youngs_modulus = 1e12/; s/^fracture = true/fracture = false/"
  "nu = 0|s/^poisson_ratio = .*/poisson_ratio = 0.0/"
  "nu = 0.4999, no fracture|s/^poisson_ratio = .*/poisson_ratio = 0.4999/; s/^fracture = true/fracture = false/"
  "toughness 0|s/^toughness = .*/toughness = 0.0/"
  "toughness inf|/^toughness = /d"
  "density 1e-3|s/^density = .*/density = 1e-3/"
  "density 1e6|s/^density = .*/density = 1e6/"
  "ball 1000 m/s|s/^velocity = \[12.0/velocity = [1000.0/"
  "gravity 1e4|s/^gravity = .*/gravity = [0.0, -1e4, 0.0]/"
  "self-collision off|s/^self_collision = true/self_collision = false/"
)
echo "| case | peak ÷ put in | fragments | splits | ms/step mean | ms/step max | sphere / vertex penetration mm | outcome |"
echo "|---|---|---|---|---|---|---|---|"
for entry in "${cases[@]}"; do
  name=${entry%%|*}
  expression=${entry#*|}
  scene="$work/scene.toml"
  sed -e "s|\"../../out/bunny-5k.h5\"|\"$bundle\"|" -e "$expression" "$sample" > "$scene"
  report="$work/report.json"
  rm -f "$report"
  outcome=completed
  timeout "$limit" "$player" -q run "$scene" --steps "$steps" --no-render --no-energy-check --report "$report" \
    > /dev/null 2>&1 || outcome="exit $? (124: over ${limit} s)"
  if [[ -f $report ]]; then
    python3 - "$report" "$name" "$outcome" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
s, t = r["summary"], r["timings"]["step"]
put_in = s["energy_initial_J"] + s.get("energy_put_in_J", 0.0)
print(f"| {sys.argv[2]} | {s['energy_max_J'] / put_in:.3g} | {s['fragments']} | {s['splits']} | "
      f"{t['mean_ms']:.2f} | {t['max_ms']:.1f} | "
      f"{1e3 * s['sphere_penetration_max_m']:.2f} / {1e3 * s['vertex_penetration_max_m']:.2f} | {sys.argv[3]} |")
PY
  else
    echo "| $name | – | – | – | – | – | – | $outcome, no report |"
  fi
done
