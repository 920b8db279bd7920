#!/usr/bin/env bash
# The sample scene on an automatic cage (issue 43): bake data/meshes/bunny-5k.obj with
# `--tets 1000` (no --cage), play data/scenes/bunny-drop.toml's 480 steps on it (the
# drop, the ball, the fracture) and check that the run completed within the energy
# bound: the player stops a run whose energy exceeds what it started with plus what was
# put in, so "completed" with no energy_gain is the bound held. About 5 s.
# Usage: auto_cage_sample_test.sh FISSURE_BAKE FISSURE_PLAYER REPOSITORY_ROOT
set -euo pipefail
bake=$1 player=$2 root=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$bake" -q bake --mesh "$root/data/meshes/bunny-5k.obj" --tets 1000 -o "$work/auto.h5" || fail "the bake failed"
sed 's|^bundle = .*|bundle = "auto.h5"|' "$root/data/scenes/bunny-drop.toml" >"$work/scene.toml"
grep -q '^bundle = "auto.h5"' "$work/scene.toml" || fail "the scene's bundle line was not replaced"
"$player" run "$work/scene.toml" --no-render --steps 480 --report "$work/report.json" >"$work/run.txt" 2>&1 ||
  fail "the run failed: $(tail -5 "$work/run.txt")"
python3 - "$work/report.json" <<'PY' || fail "the report: $(cat "$work/run.txt")"
import json, sys
r = json.load(open(sys.argv[1]))
s = r["summary"]
assert r["status"]["outcome"] == "completed", r["status"]
assert r["steps"] == 480, r["steps"]
assert s["energy_gain"] == "", s["energy_gain"]
assert s["energy_max_J"] <= 1.001 * (s["energy_initial_J"] + s["energy_put_in_J"]), s
assert s["splits"] > 0, "the ball did not break the bunny"
print(f"480 steps on {r['bodies'][0].get('tets', '?')} tets: energy {s['energy_initial_J']:.3f} J -> {s['energy_final_J']:.3f} J "
      f"(max {s['energy_max_J']:.3f} J, {s['energy_put_in_J']:.3f} J put in), {s['splits']} splits, {s['fragments']} fragments")
PY
