#!/usr/bin/env bash
# What answering large fragments rigidly costs in fidelity, against the all-deformable
# model (solver.rigid_resting_speed = 0), on the sample's 12 variants (toughness, ball
# speed, friction, as scripts/sample-variants.sh). Fracture is chaotic, so a single
# variant's pieces say little: each setting is compared with the spread of the
# all-deformable runs themselves under a change of the numerics alone
# (contact_iterations = 9, tolerance 0.99e-5). Per setting it prints the mean step, the
# splits, the mass broken off the largest piece and the pieces, summed over the
# variants. The mass comes from replaying each run's splits (its trajectory) on the
# bundle's tets. Needs out/bunny-5k.h5 (scripts/bake-sample.sh) and python3-h5py.
# About 1 minute per setting on 2 cores.
#   usage: scripts/rigid-fidelity.sh [PLAYER] [SPEEDS]    (default: the release build's; "0.2 0.5 1")
set -euo pipefail
cd "$(dirname "$0")/.."
player=$(realpath "${1:-build/release/player/app/fissure-player}")
speeds=${2:-0.2 0.5 1}
[[ -f out/bunny-5k.h5 ]] || { echo "error: out/bunny-5k.h5 is missing" >&2; echo "hint: run scripts/bake-sample.sh first" >&2; exit 1; }
# shellcheck source=scripts/system-python.sh
source scripts/system-python.sh
python=$(python_with h5py python3-h5py) || exit 1
export OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-Prescott}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bundle=$(realpath out/bunny-5k.h5)

# Plays the 12 variants into $work/$1/ with the sed expression $2 applied to the scene
# and the lines $3 added to its [solver] table.
variants() {
  local setting=$1 expression=$2 lines=$3
  mkdir -p "$work/$setting"
  echo "  $setting …" >&2
  for toughness in 0.6 0.8 1.0; do
    for speed in 10 14; do
      for friction in 0.4 0.8; do
        local name="t${toughness}_v${speed}_f${friction}"
        sed -e "s|\"../../out/bunny-5k.h5\"|\"$bundle\"|" -e "$expression" \
          -e "s/^toughness = .*/toughness = $toughness/; s/^velocity = \[12.0/velocity = [$speed.0/; s/^friction = .*/friction = $friction/" \
          -e "s|^\[solver\]\$|[solver]\n$lines|" data/scenes/bunny-drop.toml > "$work/$setting/$name.toml"
        "$player" -q run "$work/$setting/$name.toml" --steps 480 --no-render --no-energy-check -j 2 \
          --report "$work/$setting/$name.json" --trajectory "$work/$setting/$name.h5" --trajectory-every 480 \
          > /dev/null 2>&1 || echo "warning: $setting/$name exited $?" >&2
      done
    done
  done
}
variants "all-deformable" "" "rigid_resting_speed = 0"
variants "all-deformable, contact_iterations 9" "" "rigid_resting_speed = 0\ncontact_iterations = 9"
variants "all-deformable, tolerance 0.99e-5" "s/^tolerance = .*/tolerance = 0.99e-5/" "rigid_resting_speed = 0"
for s in $speeds; do variants "rigid_resting_speed $s" "" "rigid_resting_speed = $s"; done

"$python" - "$work" "$bundle" <<'PY'
import json, pathlib, re, statistics, sys
import h5py
import numpy as np

work, bundle = pathlib.Path(sys.argv[1]), h5py.File(sys.argv[2], "r")
rest = bundle["/cage/rest_positions"][:]
cage_tets = bundle["/cage/tets"][:].astype(np.int64)
corners = rest[cage_tets]
volumes = np.abs(np.einsum("ij,ij->i", corners[:, 1] - corners[:, 0],
                           np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 0]))) / 6
density = float(re.search(r"^density = ([0-9.e+-]+)", pathlib.Path("data/scenes/bunny-drop.toml").read_text(), re.M)[1])
tet_mass = density * bundle["/collision/mass_fraction"][:] * volumes

def piece_masses(trajectory):
    """Each piece's mass [kg] at the end: the splits replayed on the cage's tets
    (each moves its tets from the split node to the added one), then tets sharing a node
    joined."""
    tets = cage_tets.copy()
    splits = h5py.File(trajectory, "r")["/events/splits"]
    node, added, offsets, moved = (splits[k][:] for k in ("node", "added", "moved_offsets", "moved_tets"))
    for e in range(len(node)):
        for t in moved[offsets[e]:offsets[e + 1]]:
            tets[t][tets[t] == node[e]] = added[e]
    parent = list(range(int(tets.max()) + 1))
    def root(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for t in tets:
        for c in t[1:]:
            parent[root(int(t[0]))] = root(int(c))
    mass = {}
    for t, m in zip(tets, tet_mass):
        mass[root(int(t[0]))] = mass.get(root(int(t[0])), 0.0) + m
    return sorted(mass.values(), reverse=True), len(node)

print("| setting | step ms (mean) | splits | broken off the largest piece, g | pieces |")
print("|---|---:|---:|---:|---:|")
for setting in sorted((p for p in work.iterdir() if p.is_dir()), key=lambda p: (not p.name.startswith("all"), p.name)):
    steps, splits, broken, pieces = [], 0, 0.0, 0
    for report in sorted(setting.glob("*.json")):
        steps.append(json.loads(report.read_text())["timings"]["step"]["mean_ms"])
        masses, n = piece_masses(report.with_suffix(".h5"))
        splits, broken, pieces = splits + n, broken + 1000 * sum(masses[1:]), pieces + len(masses)
    if steps:
        print(f"| {setting.name} | {statistics.mean(steps):.2f} | {splits} | {broken:.0f} | {pieces} |")
print()
print("Sums over the 12 variants; the all-deformable rows' spread is the chaos of the break-up.")
PY
