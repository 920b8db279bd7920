#!/usr/bin/env bash
# Same-run A/B of two fissure-player binaries on variants of the sample scene: fracture
# is chaotic, so one run of the sample cannot tell a change's cost from a different
# break-up. Each variant changes the bunny's toughness, the ball's speed and the
# friction; each binary runs each variant once, alternating (out/bunny-5k.h5: run
# scripts/bake-sample.sh first). Prints a Markdown table per variant and the geometric
# means of the ratios (B ÷ A). A change to the bake plays each side's own bundle:
# BUNDLE_A and BUNDLE_B (default out/bunny-5k.h5 for both). A setting's A/B with one
# player: SOLVER_A and SOLVER_B, lines added to that side's [solver] table. A wider
# set (the standard 12 are narrow: one variant's step moves 0.5–4× with its break-up):
# TOUGHNESS, SPEEDS and FRICTIONS, space-separated lists (defaults "0.6 0.8 1.0",
# "10 14", "0.4 0.8"); STEP_LOGS=DIR keeps each run's `--step-log` there.
#   usage: [BUNDLE_A=A.h5 BUNDLE_B=B.h5] [SOLVER_A=… SOLVER_B=…] scripts/sample-variants.sh PLAYER_A PLAYER_B [STEPS]
#          (STEPS default 480; e.g. SOLVER_B="rigid_resting_speed = 0.2", TOUGHNESS="0.6 0.7 0.8 0.9")
set -euo pipefail
cd "$(dirname "$0")/.."
[[ $# -ge 2 ]] || { sed -n '2,15p' "$0" >&2; exit 2; }
a=$(realpath "$1")
b=$(realpath "$2")
steps=${3:-480}
bundle_a=${BUNDLE_A:-out/bunny-5k.h5}
bundle_b=${BUNDLE_B:-out/bunny-5k.h5}
for f in "$bundle_a" "$bundle_b"; do
  [[ -f $f ]] || { echo "error: $f is missing" >&2; echo "hint: run scripts/bake-sample.sh first" >&2; exit 1; }
done
export OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-Prescott}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bundle_a=$(realpath "$bundle_a")
bundle_b=$(realpath "$bundle_b")
step_logs=()
[[ -n ${STEP_LOGS:-} ]] && mkdir -p "$STEP_LOGS"
for toughness in ${TOUGHNESS:-0.6 0.8 1.0}; do
  for speed in ${SPEEDS:-10 14}; do
    for friction in ${FRICTIONS:-0.4 0.8}; do
      name="t${toughness}_v${speed}_f${friction}"
      for side in a b; do
        player=$a bundle=$bundle_a solver=${SOLVER_A:-}
        [[ $side == b ]] && player=$b bundle=$bundle_b solver=${SOLVER_B:-}
        sed -e "s|\"../../out/bunny-5k.h5\"|\"$bundle\"|" -e "s/^toughness = .*/toughness = $toughness/" \
          -e "s/^velocity = \[12.0/velocity = [$speed.0/" -e "s/^friction = .*/friction = $friction/" \
          -e "s|^\[solver\]\$|[solver]\n$solver|" data/scenes/bunny-drop.toml > "$work/$name.$side.toml"
        [[ -n ${STEP_LOGS:-} ]] && step_logs=(--step-log "$STEP_LOGS/$name.$side.csv")
        "$player" -q run "$work/$name.$side.toml" --steps "$steps" --no-render --no-energy-check \
          --report "$work/$name.$side.json" "${step_logs[@]}" > /dev/null 2>&1 || echo "warning: $name ($side) exited $?" >&2
      done
    done
  done
done
python3 - "$work" <<'PY'
import json, math, pathlib, sys
work = pathlib.Path(sys.argv[1])
def figures(path):
    r = json.loads(path.read_text())
    s, steps, t = r["summary"], r["steps"], r["timings"]
    put_in = s["energy_initial_J"] + s.get("energy_put_in_J", 0.0)
    return {"cg": s["contact_response_iterations"] / steps, "coll": t["collisions"]["mean_ms"],
            "step": t["step"]["mean_ms"], "p99": t["step"]["p99_ms"], "spheres": sum(b["spheres"] for b in r["bodies"]),
            "frag": s["fragments"], "peak": s["energy_max_J"] / put_in,
            "sph": 1e3 * s["sphere_penetration_max_m"], "vtx": 1e3 * s["vertex_penetration_max_m"],
            "where": s.get("vertex_penetration_where", "")}
print("| variant | spheres at the end A → B | response CG/step A → B | collisions ms/step A → B | step ms mean / p99 A → B | fragments A → B | peak ÷ put in A → B | sphere / vertex penetration mm A → B | deepest vertex B |")
print("|---|---|---|---|---|---|---|---|---|")
logs = {"cg": [], "coll": [], "step": []}
worst = {"a": (0.0, ""), "b": (0.0, "")}
for a_path in sorted(work.glob("*.a.json")):
    name = a_path.name[:-len(".a.json")]
    b_path = work / f"{name}.b.json"
    if not b_path.exists():
        continue
    fa, fb = figures(a_path), figures(b_path)
    for k in logs:
        if fa[k] > 0 and fb[k] > 0:
            logs[k].append(math.log(fb[k] / fa[k]))
    for side, f in (("a", fa), ("b", fb)):
        if f["vtx"] > worst[side][0]:
            worst[side] = (f["vtx"], f"{name}: {f['where']}")
    print(f"| {name} | {fa['spheres']} → {fb['spheres']} | {fa['cg']:.1f} → {fb['cg']:.1f} | {fa['coll']:.2f} → {fb['coll']:.2f} | "
          f"{fa['step']:.2f} / {fa['p99']:.1f} → {fb['step']:.2f} / {fb['p99']:.1f} | {fa['frag']} → {fb['frag']} | "
          f"{fa['peak']:.3f} → {fb['peak']:.3f} | {fa['sph']:.2f} / {fa['vtx']:.2f} → {fb['sph']:.2f} / {fb['vtx']:.2f} | {fb['where']} |")
for k, v in logs.items():
    if v:
        print(f"geometric mean B ÷ A, {k}: {math.exp(sum(v) / len(v)):.3f} over {len(v)} variants")
for side in ("a", "b"):
    print(f"deepest render vertex, {side.upper()}: {worst[side][0]:.2f} mm ({worst[side][1]})")
PY
