#!/usr/bin/env bash
# What answering an unbreakable body's contacts rigidly costs in fidelity (record 0078):
# the sample with fracture off, played at each solver.rigid_resting_speed against the
# all-deformable model (0) and against that model under a change of the numerics alone
# (contact_iterations = 9), the yardstick for what a tumbling body's chaos moves anyway.
# The measure is the body's deformation frame by frame: the RMS distance of its nodes
# from the rest shape after the best rigid fit (Kabsch). Per setting it prints the mean
# step, the collision phase's share, the mean |difference| of the deformation from the
# all-deformable run's, its peak (the ball's hit) and the squash on landing (before the
# ball). Needs out/bunny-5k.h5 (scripts/bake-sample.sh), h5dump (hdf5-tools) and numpy
# (python3-matplotlib brings it). About 10 s per setting on 2 cores.
#   usage: scripts/deformation-fidelity.sh [PLAYER] [SPEEDS]    (default: the release build's; "0.5 1 2")
set -euo pipefail
cd "$(dirname "$0")/.."
player=$(realpath "${1:-build/release/player/app/fissure-player}")
speeds=${2:-0.5 1 2}
[[ -f out/bunny-5k.h5 ]] || { echo "error: out/bunny-5k.h5 is missing" >&2; echo "hint: run scripts/bake-sample.sh first" >&2; exit 1; }
command -v h5dump > /dev/null || { echo "error: h5dump is missing" >&2; echo "hint: apt-get install -y hdf5-tools" >&2; exit 1; }
# shellcheck source=scripts/system-python.sh
source scripts/system-python.sh
python=$(python_with numpy python3-numpy) || exit 1
export OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-Prescott}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bundle=$(realpath out/bunny-5k.h5)

# Plays the sample with fracture off and the lines $2 in its [solver] table; the report
# lands in $work/$1.json, the node positions of every second step in $work/$1.bin.
play() {
  local name=$1 lines=$2
  echo "  $name …" >&2
  sed -e "s|\"../../out/bunny-5k.h5\"|\"$bundle\"|" -e "s/^fracture = true/fracture = false/" \
    -e "s|^\[solver\]\$|[solver]\n$lines|" data/scenes/bunny-drop.toml > "$work/$name.toml"
  "$player" -q run "$work/$name.toml" --steps 480 --no-render --no-energy-check -j 2 --report "$work/$name.json" \
    --trajectory "$work/$name.h5" --trajectory-every 2 > /dev/null 2>&1 || echo "warning: $name exited $?" >&2
  h5dump -d /bodies/0/positions -b LE -o "$work/$name.bin" "$work/$name.h5" > /dev/null
}
play "all-deformable" "rigid_resting_speed = 0"
play "all-deformable, contact_iterations 9" "rigid_resting_speed = 0\ncontact_iterations = 9"
names=("all-deformable, contact_iterations 9")
for s in $speeds; do
  play "rigid_resting_speed $s" "rigid_resting_speed = $s"
  names+=("rigid_resting_speed $s")
done

"$python" - "$work" "${names[@]}" <<'PY'
import json, pathlib, sys
import numpy as np

work = pathlib.Path(sys.argv[1])
BALL_FRAME = 60  # the ball is launched at 0.5 s = step 120, frame 60 at every second step

def frames(name):
    nodes = json.loads((work / f"{name}.json").read_text())["bodies"][0]["nodes_final"]
    return np.fromfile(work / f"{name}.bin", dtype="<f8").reshape(-1, nodes, 3)

def deformation(P):
    """Per frame, the RMS distance of the nodes from frame 0's shape after the best rigid fit."""
    rest = P[0] - P[0].mean(axis=0)
    out = []
    for X in P:
        Y = X - X.mean(axis=0)
        U, _, Vt = np.linalg.svd(rest.T @ Y)
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
        R = U @ D @ Vt  # rest @ R ≈ Y
        out.append(np.sqrt(((rest @ R - Y) ** 2).sum(axis=1).mean()))
    return np.array(out)

reference = deformation(frames("all-deformable"))
print("| setting | step ms | collisions (share) | deformation vs all-deformable, mean mm | peak mm | landing squash mm |")
print("|---|---:|---:|---:|---:|---:|")
for name in ["all-deformable"] + sys.argv[2:]:
    t = json.loads((work / f"{name}.json").read_text())["timings"]
    d = deformation(frames(name))
    apart = "–" if name == "all-deformable" else f"{1e3 * np.abs(d - reference).mean():.2f}"
    step, coll = t["step"]["mean_ms"], t["collisions"]["mean_ms"]
    print(f"| {name} | {step:.2f} | {coll:.3f} ({100 * coll / step:.0f} %) | {apart} | "
          f"{1e3 * d.max():.2f} | {1e3 * d[:BALL_FRAME].max():.2f} |")
PY
