#!/usr/bin/env bash
# pipelines/batch/Snakefile run locally on three assets (issue 18): everything bakes,
# verified, with a JUnit report; a second run does nothing; editing one mesh, one cage
# half or one asset's options re-bakes only what uses it (files are edited, not touched:
# snakemake 7 compares the checksums of inputs under 1 MB, so a touch alone is no
# change there); a broken asset fails alone (--keep-going)
# and leaves no temporary. Works on copies, so the repository is never touched.
# Usage: snakemake_test.sh FISSURE_BAKE REPOSITORY_ROOT
set -euo pipefail
bake=$1 root=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

mkdir -p "$work/library/meshes" "$work/library/cages" "$work/run"
cp "$root"/data/meshes/bunny-5k.obj "$root"/data/meshes/bunny-5k-open.obj "$work/library/meshes/"
cp "$root"/data/cages/bunny-5k-cage-10.* "$root"/data/cages/bunny-5k-cage-100.* "$work/library/cages/"
cat >"$work/library/assets.yaml" <<'YAML'
assets:
  hero:
    mesh: meshes/bunny-5k.obj
    cage: cages/bunny-5k-cage-100.node
  prop:
    mesh: meshes/bunny-5k.obj
    cage: cages/bunny-5k-cage-10.ele
    options: --wall-res 16
  open:
    mesh: meshes/bunny-5k-open.obj
    cage: cages/bunny-5k-cage-10.node
    options: --skip walls
YAML
run() {
  (cd "$work/run" && snakemake --snakefile "$root/pipelines/batch/Snakefile" --cores 2 --keep-going \
    --config manifest="$work/library/assets.yaml" bake="$bake" "$@" 2>&1)
}
baked() { grep -o 'wildcards: name=[a-z]*' <<<"$1" | sed 's/wildcards: name=//' | sort | tr '\n' ' '; }

out=$(run) || fail "the first run failed: $out"
[ "$(baked "$out")" = "hero open prop " ] || fail "the first run baked: $(baked "$out")"$'\n'"$out"
grep -q 'failures="0" errors="0">' "$work/run/bundles/verify-report.xml" || fail "the report: $(head -3 "$work/run/bundles/verify-report.xml")"
"$bake" status "$work"/run/bundles/*.h5 >/dev/null || fail "status calls a fresh bundle stale"

out=$(run) || fail "the second run failed: $out"
grep -q "Nothing to be done" <<<"$out" || fail "the second run was not empty: $out"

sleep 1  # mtime resolution: the edited mesh must be newer than the bundles
echo "# edited" >>"$work/library/meshes/bunny-5k-open.obj"
out=$(run) || fail "the run after editing a mesh failed: $out"
[ "$(baked "$out")" = "open " ] || fail "editing the open mesh re-baked: $(baked "$out")"

sed -i 's/--wall-res 16/--wall-res 8/' "$work/library/assets.yaml"
out=$(run) || fail "the run after editing options failed: $out"
[ "$(baked "$out")" = "prop " ] || fail "editing prop's options re-baked: $(baked "$out")"

sleep 1
echo "# edited" >>"$work/library/cages/bunny-5k-cage-10.ele"
out=$(run) || fail "the run after editing a cage half failed: $out"
[ "$(baked "$out")" = "open prop " ] || fail "editing the .ele re-baked: $(baked "$out")"$'\n'"$out"

# One broken asset: its job fails and says why, the others are untouched.
echo "f 1 2 999999" >>"$work/library/meshes/bunny-5k-open.obj"
if out=$(run); then fail "a broken asset did not fail the run: $out"; fi
grep -q "error: .*bunny-5k-open.obj" <<<"$out" || fail "the failure does not name the mesh: $out"
[ -z "$(find "$work/run/bundles" -name '*.building.h5')" ] || fail "a temporary bundle was left"
[ -f "$work/run/bundles/hero.h5" ] && [ -f "$work/run/bundles/prop.h5" ] || fail "a good bundle went missing"
echo "snakemake batch: all checks passed"
