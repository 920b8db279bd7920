#!/usr/bin/env bash
# Same-run A/B of two fissure-player binaries on variants of the sample scene: fracture
# is chaotic, so one run of the sample cannot tell a change's cost from a different
# break-up. Each variant changes the bunny's toughness, the ball's speed and the
# friction; each binary runs each variant once, alternating (out/bunny-5k.h5: run
# scripts/bake-sample.sh first). Prints a Markdown table per variant and the geometric
# means of the ratios (B ÷ A).
#   usage: scripts/sample-variants.sh PLAYER_A PLAYER_B [STEPS]    (default 480)
set -euo pipefail
cd "$(dirname "$0")/.."
[[ $# -ge 2 ]] || { sed -n '2,8p' "$0" >&2; exit 2; }
a=$(realpath "$1")
b=$(realpath "$2")
steps=${3:-480}
[[ -f out/bunny-5k.h5 ]] || { echo "error: out/bunny-5k.h5 is missing" >&2; echo "hint: run scripts/bake-sample.sh first" >&2; exit 1; }
export OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-Prescott}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bundle=$(realpath out/bunny-5k.h5)
for toughness in 0.6 0.8 1.0; do
  for speed in 10 14; do
    for friction in 0.4 0.8; do
      name="t${toughness}_v${speed}_f${friction}"
      sed -e "s|\"../../out/bunny-5k.h5\"|\"$bundle\"|" -e "s/^toughness = .*/toughness = $toughness/" \
        -e "s/^velocity = \[12.0/velocity = [$speed.0/" -e "s/^friction = .*/friction = $friction/" \
        data/scenes/bunny-drop.toml > "$work/$name.toml"
      for side in a b; do
        player=$a
        [[ $side == b ]] && player=$b
        "$player" -q run "$work/$name.toml" --steps "$steps" --no-render --no-energy-check \
          --report "$work/$name.$side.json" > /dev/null 2>&1 || echo "warning: $name ($side) exited $?" >&2
      done
    done
  done
done
python3 - "$work" <<'PY'
import json, math, pathlib, sys
work = pathlib.Path(sys.argv[1])
def figures(path):
    r = json.loads(path.read_text())
    s, steps = r["summary"], r["steps"]
    put_in = s["energy_initial_J"] + s.get("energy_put_in_J", 0.0)
    return {"cg": s["contact_response_iterations"] / steps, "coll": r["timings"]["collisions"]["mean_ms"],
            "frag": s["fragments"], "peak": s["energy_max_J"] / put_in,
            "sph": 1e3 * s["sphere_penetration_max_m"], "vtx": 1e3 * s["vertex_penetration_max_m"]}
print("| variant | response CG/step A → B | collisions ms/step A → B | fragments A → B | peak ÷ put in A → B | sphere / vertex penetration mm A → B |")
print("|---|---|---|---|---|---|")
logs = {"cg": [], "coll": []}
for a_path in sorted(work.glob("*.a.json")):
    name = a_path.name[:-len(".a.json")]
    b_path = work / f"{name}.b.json"
    if not b_path.exists():
        continue
    fa, fb = figures(a_path), figures(b_path)
    for k in logs:
        if fa[k] > 0 and fb[k] > 0:
            logs[k].append(math.log(fb[k] / fa[k]))
    print(f"| {name} | {fa['cg']:.1f} → {fb['cg']:.1f} | {fa['coll']:.2f} → {fb['coll']:.2f} | {fa['frag']} → {fb['frag']} | "
          f"{fa['peak']:.3f} → {fb['peak']:.3f} | {fa['sph']:.2f} / {fa['vtx']:.2f} → {fb['sph']:.2f} / {fb['vtx']:.2f} |")
for k, v in logs.items():
    if v:
        print(f"geometric mean B ÷ A, {k}: {math.exp(sum(v) / len(v)):.3f} over {len(v)} variants")
PY
