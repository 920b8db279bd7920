#!/usr/bin/env bash
# pipelines/batch/Snakefile run locally on three assets (issue 18): everything bakes,
# verified, with a JUnit report; a second run does nothing; editing one mesh, one cage
# half or one asset's options re-bakes only what uses it (files are edited, not touched:
# snakemake 7 compares the checksums of inputs under 1 MB, so a touch alone is no
# change there); a broken asset fails alone (--keep-going)
# and leaves no temporary. Issue 45: a failed re-bake keeps the last good bundle byte for
# byte and the report fails with it (until a good bake); moving the library with its
# bundles re-bakes nothing. Works on copies, so the repository is never touched.
# Usage: snakemake_test.sh FISSURE_BAKE REPOSITORY_ROOT
set -euo pipefail
bake=$1 root=$2
top=$(mktemp -d)
trap 'rm -rf "$top"' EXIT
work=$top/tree
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
# The assets the bake rule ran for (publish jobs name their asset too).
baked() { awk '/^(local)?rule /{rule=$2} /wildcards: name=/{if (rule == "bake:") {sub(/.*name=/, ""); print}}' <<<"$1" | sort | tr '\n' ' '; }
failures() { python3 -c 'import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); print(int(r.get("failures")) + int(r.get("errors")))' "$1"; }

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

# One broken asset: its job fails and says why, the others are untouched, its last good
# bundle stays byte for byte, and the report fails on it (issue 45: snakemake deleted the
# bundle and left the old all-green report).
cp "$work/library/meshes/bunny-5k-open.obj" "$top/open.obj.good"
before=$(sha256sum <"$work/run/bundles/open.h5")
echo "f 1 2 999999" >>"$work/library/meshes/bunny-5k-open.obj"
if out=$(run); then fail "a broken asset did not fail the run: $out"; fi
grep -q "error: .*bunny-5k-open.obj" <<<"$out" || fail "the failure does not name the mesh: $out"
[ -z "$(find "$work/run/bundles" -name '*.building.h5')" ] || fail "a temporary bundle was left"
[ -f "$work/run/bundles/hero.h5" ] && [ -f "$work/run/bundles/prop.h5" ] || fail "a good bundle went missing"
[ -f "$work/run/bundles/open.h5" ] || fail "the failed re-bake deleted the last good bundle"
[ "$before" = "$(sha256sum <"$work/run/bundles/open.h5")" ] || fail "the failed re-bake changed the last good bundle"
report=$work/run/bundles/verify-report.xml
[ "$(failures "$report")" -gt 0 ] || fail "the report stays green over a failed bake: $(head -3 "$report")"
grep -q '<testcase classname="bundles/open.h5" name="bake"><failure message="the last bake failed' "$report" \
  || fail "the report has no failing bake case for open: $(cat "$report")"
# A second run retries the failed bake, and fails and reports it again.
if out=$(run); then fail "the failed bake was not retried: $out"; fi
[ "$(baked "$out")" = "open " ] || fail "the retry baked: $(baked "$out")"
[ "$(failures "$report")" -gt 0 ] || fail "the report went green with the bake still failing"

# Mended, the asset bakes again and the report is green.
cp "$top/open.obj.good" "$work/library/meshes/bunny-5k-open.obj"
out=$(run) || fail "the run after mending the mesh failed: $out"
[ "$(baked "$out")" = "open " ] || fail "mending the mesh re-baked: $(baked "$out")"
[ "$(failures "$report")" = 0 ] || fail "the report of a mended library: $(cat "$report")"
[ -z "$(find "$work/run/bundles" -name '*.failed')" ] || fail "a failure marker outlived a good bake"

# Moving the library with its bundles (and snakemake's records) re-bakes nothing.
mv "$work" "$top/moved"
work=$top/moved
out=$(run) || fail "the run after moving the library failed: $out"
grep -q "Nothing to be done" <<<"$out" || fail "moving the library re-ran: $(baked "$out")"$'\n'"$out"
"$bake" status "$work"/run/bundles/*.h5 >/dev/null || fail "status calls a moved bundle stale"
# Every document the Snakefile points to exists (issue 45: pipelines/batch/README.md did not).
for doc in $(grep -o 'pipelines/[A-Za-z/_.-]*\.md' "$root/pipelines/batch/Snakefile" | sort -u); do
  [ -f "$root/$doc" ] || fail "the Snakefile points to $doc, which does not exist"
done
echo "snakemake batch: all checks passed"
