#!/usr/bin/env bash
# Sphere radius vs penetration vs collision time (issue 4): bakes the sample bunny at
# several collision-sphere radii, plays the same scene with each bundle in "spheres"
# mode and once in the exact "vertices" mode (every render vertex a contact point),
# and prints a Markdown table for BENCHMARKS.md.
#
# Usage: scripts/sweep-sphere-radius.sh [--steps N] [--threads N] [--time-limit S] [--no-fracture]
#                                       [--scene S]
#   --steps N      player steps per run (default 480: bunny-drop's 2 s at 1/240 s; 119
#                  stops before its ball is launched at 0.5 s, leaving only the drop)
#   --threads N    player worker threads (default 1, so collision times compare across runs)
#   --time-limit S stop a player run after S seconds of wall clock (default 60) and mark its
#                  row as stopped: fine spheres can make a step take seconds once a body breaks
#   --no-fracture  set features.fracture = false, so every run keeps the same topology and
#                  only the collision points differ
#   --scene S      base scene with one [[object]] (default data/scenes/bunny-drop.toml);
#                  its bundle and features.collision_mode are replaced per run
#
# It does not build: build fissure-bake and fissure-player first (scripts/bake-sample.sh
# does). Bundles, scenes and reports go to out/sphere-radius-sweep/.
set -euo pipefail
cd "$(dirname "$0")/.."

steps=480
threads=1
time_limit=60
fracture=
base_scene=data/scenes/bunny-drop.toml
while [ $# -gt 0 ]; do
  case "$1" in
    --steps) steps="${2:?--steps needs a value}"; shift 2 ;;
    --threads) threads="${2:?--threads needs a value}"; shift 2 ;;
    --time-limit) time_limit="${2:?--time-limit needs a value}"; shift 2 ;;
    --no-fracture) fracture=false; shift ;;
    --scene) base_scene="${2:?--scene needs a value}"; shift 2 ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    *)
      echo "error: unknown option '$1'" >&2
      echo "hint: options: --steps N, --threads N, --time-limit S, --no-fracture, --scene S, --help" >&2
      exit 1 ;;
  esac
done

bake=build/release/bake/fissure-bake
player=build/release/player/app/fissure-player
for binary in "$bake" "$player"; do
  if [ ! -x "$binary" ]; then
    echo "error: $binary is not built" >&2
    echo "hint: build it first: cmake --build build/release --target fissure-bake fissure-player (or run scripts/bake-sample.sh)" >&2
    exit 1
  fi
done
if ! command -v h5dump > /dev/null; then
  echo "error: h5dump not found (it reads the baked sphere radii)" >&2
  echo "hint: install hdf5-tools (bash scripts/install-deps.sh)" >&2
  exit 1
fi
if [ ! -f "$base_scene" ]; then
  echo "error: scene $base_scene not found" >&2
  exit 1
fi
if [ "$(grep -c '^[[:space:]]*bundle[[:space:]]*=' "$base_scene")" != 1 ]; then
  echo "error: $base_scene must name exactly one bundle (one [[object]]) for this sweep" >&2
  exit 1
fi

mesh=data/meshes/bunny-5k.obj
cage=data/cages/bunny-5k-cage-987.node
work=out/sphere-radius-sweep
mkdir -p "$work"

# Sets `key = value` in the [features] table of scene file $1: replaces the key where the
# scene has it, else adds it right under [features], or in a new [features] table at the
# end (a table header may appear only once in TOML).
set_feature() {
  local scene="$1" key="$2" value="$3"
  if grep -q "^[[:space:]]*$key[[:space:]]*=" "$scene"; then
    sed -i "s|^\([[:space:]]*$key[[:space:]]*=\).*|\1 $value|" "$scene"
  elif grep -q '^\[features\]' "$scene"; then
    sed -i "s|^\[features\].*|&\n$key = $value|" "$scene"
  else
    printf '\n[features]\n%s = %s\n' "$key" "$value" >> "$scene"
  fi
}

# Writes $work/<name>.toml: the base scene with its bundle and collision mode replaced.
# The bundle is named relative to the scene (the reader resolves it from the scene's
# folder), so no path of this machine ends up in the file.
write_scene() {
  local name="$1" bundle="$2" mode="$3" scene="$work/$1.toml"
  sed "s|^\([[:space:]]*bundle[[:space:]]*=\).*|\1 \"$bundle\"|" "$base_scene" > "$scene"
  set_feature "$scene" collision_mode "\"$mode\""
  if [ -n "$fracture" ]; then set_feature "$scene" fracture "$fracture"; fi
  echo "$scene"
}

# The radii the bake actually chose: it halves a tet's radius until the tet holds 3
# spheres, so the target radius is only an upper bound. Written comma-separated.
dump_radii() {
  h5dump -y -w 0 -d /collision/sphere_radius -o "$2" "$1" > /dev/null
}

# A run that passes the time limit leaves no report; the table marks its row as stopped.
# Any other failure stops the sweep.
play() {
  local scene="$1" report="$2" status=0
  echo "  play: $scene ($steps steps)" >&2
  rm -f "$report"
  timeout "$time_limit" "$player" -q run "$scene" --no-render --steps "$steps" -j "$threads" --report "$report" \
    > /dev/null || status=$?
  if [ "$status" = 124 ]; then
    echo "  stopped after $time_limit s: $scene" >&2
  elif [ "$status" != 0 ]; then
    echo "error: fissure-player failed on $scene (exit $status)" >&2
    exit "$status"
  fi
}

# The default radius is what the bake picks (a fifth of the cage's median edge): bake
# once without --sphere-radius and read it back, so the multiples follow the cage.
echo "bake: default radius" >&2
"$bake" -q bake --mesh "$mesh" --cage "$cage" -o "$work/bunny-default.h5" >&2
default_radius=$("$bake" inspect "$work/bunny-default.h5" | sed -n 's/.*target radius \([0-9.eE+-]*\)).*/\1/p')
if [ -z "$default_radius" ]; then
  echo "error: could not read the target radius from '$bake inspect $work/bunny-default.h5'" >&2
  exit 1
fi

runs=()
# Below the default the radius really shrinks; above it the bake's 3-spheres-per-tet rule
# halves most tets back down (on the sample cage the median radius stays at half the
# default), so only a few tets keep the larger spheres.
for factor in 0.125 0.25 0.5 1 2 4; do
  if [ "$factor" = 1 ]; then
    bundle=bunny-default.h5
    radius="$default_radius"
  else
    radius=$(python3 -c "print(f'{$factor * $default_radius:.4g}')")
    bundle="bunny-r${factor}x.h5"
    echo "bake: radius $radius m (${factor}× default)" >&2
    "$bake" -q bake --mesh "$mesh" --cage "$cage" -o "$work/$bundle" --sphere-radius "$radius" >&2
  fi
  dump_radii "$work/$bundle" "$work/${bundle%.h5}-radii.txt"
  scene=$(write_scene "spheres-${factor}x" "$bundle" spheres)
  play "$scene" "$work/spheres-${factor}x-report.json"
  runs+=("spheres, ${factor}× default: $radius m=$work/spheres-${factor}x-report.json=$work/${bundle%.h5}-radii.txt")
done
# The exact mode collides every render vertex and never reads the spheres, so one run
# on any bundle of the same mesh and cage is the reference for all of them.
scene=$(write_scene exact bunny-default.h5 vertices)
play "$scene" "$work/exact-report.json"
runs+=("**exact (vertices), reference**=$work/exact-report.json=")

echo
echo "$(basename "$base_scene")${fracture:+, fracture off}, $steps steps, $threads thread(s); penetration is the maximum over the run"
echo
python3 - "$time_limit" "${runs[@]}" <<'EOF'
import json, os, statistics, sys

def mm(metres):  # below a nanometre is round-off of a resting contact, not penetration
    return "0 mm" if metres < 1e-9 else f"{1e3 * metres:.3g} mm"

def read_radii(path):
    return [float(x) for x in open(path).read().replace(",", " ").split()] if path else []

def radius_spread(radii):
    return f"{1e3 * statistics.median(radii):.3g} / {1e3 * max(radii):.3g} mm" if radii else "—"

print("| collision points, target radius | spheres | sphere radius, median / max | max render-vertex penetration | "
      "max sphere penetration | collisions ms/step (mean) | step ms (mean) | fracture splits |")
print("|---|---|---|---|---|---|---|---|")
time_limit = sys.argv[1]
for label, path, radii in (a.split("=", 2) for a in sys.argv[2:]):
    radii = read_radii(radii)
    if not os.path.exists(path):
        print(f"| {label} | {len(radii)} | {radius_spread(radii)} | stopped: over {time_limit} s of wall clock | | | | |")
        continue
    r = json.load(open(path))
    s, t, body = r["summary"], r["timings"], r["bodies"][0]
    points = body["spheres"] if r["collision_points"] == "spheres" else f'— ({body["render_vertices"]} vertices)'
    print(f'| {label} | {points} | {radius_spread(radii)} | {mm(s["vertex_penetration_max_m"])} | '
          f'{mm(s["sphere_penetration_max_m"])} | {t["collisions"]["mean_ms"]:.2f} | {t["step"]["mean_ms"]:.2f} | '
          f'{s["splits"]} |')
EOF
