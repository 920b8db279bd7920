#!/usr/bin/env bash
# pipelines/examples/cmake-project through fissure_add_bundle() (issue 18): the first
# build bakes and verifies every bundle; a second does nothing; touching one mesh
# re-bakes only its bundle; editing one bundle's OPTIONS re-bakes only that one; a bake
# that fails leaves the last good bundle and fails the build. Works on a copy of the
# example and of its assets, so the repository's files are never touched.
# Usage: cmake_project_test.sh FISSURE_BAKE REPOSITORY_ROOT
set -euo pipefail
bake=$1 root=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

mkdir -p "$work/assets/meshes" "$work/assets/cages" "$work/pipelines"
cp "$root"/data/meshes/bunny-5k.obj "$root"/data/meshes/bunny-5k-open.obj "$work/assets/meshes/"
cp "$root"/data/cages/bunny-5k-cage-987.* "$root"/data/cages/bunny-5k-cage-100.* "$work/assets/cages/"
cp -r "$root/pipelines/cmake" "$work/pipelines/"
mkdir -p "$work/pipelines/examples" && cp -r "$root/pipelines/examples/cmake-project" "$work/pipelines/examples/"
project="$work/pipelines/examples/cmake-project"

cmake -S "$project" -B "$work/build" -G Ninja -DFISSURE_BAKE_EXECUTABLE="$bake" -DGAME_ASSETS="$work/assets" >/dev/null
build() { cmake --build "$work/build" 2>&1; }
bakes() { grep -o 'Baking bundle [a-z_]*' <<<"$1" | sed 's/Baking bundle //' | sort | tr '\n' ' '; }

out=$(build)
[ "$(bakes "$out")" = "bunny bunny_open bunny_prop " ] || fail "first build baked: $(bakes "$out")"$'\n'"$out"
grep -q "bundles/bunny.h5: all invariants hold" <<<"$out" || fail "the bundle was not verified"$'\n'"$out"
# The log names each bundle, not the temporary it was baked under (issue 45).
if grep -q "building.h5" <<<"$out"; then fail "the build log names the temporary: $out"; fi
for b in bunny bunny-prop bunny-open; do [ -f "$work/build/bundles/$b.h5" ] || fail "no bundles/$b.h5"; done
[ -z "$(find "$work/build/bundles" -name '*.building.h5')" ] || fail "a temporary bundle was left"

out=$(build)
grep -q "no work to do" <<<"$out" || fail "second build was not empty: $out"

touch "$work/assets/meshes/bunny-5k-open.obj"
out=$(build)
[ "$(bakes "$out")" = "bunny_open " ] || fail "touching the open mesh re-baked: $(bakes "$out")"

# The options as one quoted string are the same flags (issue 45: they reached the bake as
# one argument and failed).
sed -i 's/OPTIONS --wall-res 16/OPTIONS "--wall-res 8"/' "$project/CMakeLists.txt"
out=$(build)
[ "$(bakes "$out")" = "bunny_prop " ] || fail "changing bunny_prop's options re-baked: $(bakes "$out")"

# Every bundle is what its inputs give today.
"$bake" status "$work"/build/bundles/*.h5 >/dev/null || fail "status says a fresh bundle is stale"

# The CI check (pipelines/ci/check-bundles.sh): passes, then fails a budget, both with a report.
check="$root/pipelines/ci/check-bundles.sh"
FISSURE_BAKE=$bake bash "$check" "$work/report.xml" "$work"/build/bundles/*.h5 >/dev/null || fail "the CI check fails fresh bundles"
grep -q 'failures="0" errors="0">' "$work/report.xml" || fail "the JUnit report of a passing check: $(head -3 "$work/report.xml")"
set +e
out=$(FISSURE_BAKE=$bake FISSURE_MAX_TILES=100 bash "$check" "$work/report.xml" "$work"/build/bundles/*.h5 2>&1)
rc=$?
set -e
[ "$rc" = 1 ] || fail "a budget over its limit gave exit $rc: $out"
grep -q "bunny.h5: over budget" <<<"$out" || fail "the check does not name the bundle over budget: $out"
grep -q 'name="budget:tiles">' "$work/report.xml" || fail "the budget is not in the JUnit report"

# A broken mesh: the build fails, the last good bundle stays, and the next build retries.
before=$(sha256sum "$work/build/bundles/bunny-open.h5")
echo "f 1 2 999999" >>"$work/assets/meshes/bunny-5k-open.obj"
if out=$(build); then fail "a failed bake did not fail the build: $out"; fi
grep -q "error: .*bunny-5k-open.obj" <<<"$out" || fail "the failure does not name the mesh: $out"
grep -q "the last good bundle, if any, is kept" <<<"$out" || fail "the failure does not say the bundle is kept: $out"
[ -z "$(find "$work/build/bundles" -name '*.building.h5')" ] || fail "a failed bake left a temporary bundle"
[ "$before" = "$(sha256sum "$work/build/bundles/bunny-open.h5")" ] || fail "the failed bake replaced the bundle"
"$bake" status "$work/build/bundles/bunny-open.h5" >/dev/null && fail "status calls the bundle of an edited mesh up to date"
set +e
FISSURE_BAKE=$bake bash "$check" "$work/report.xml" "$work"/build/bundles/*.h5 >/dev/null 2>&1
rc=$?
set -e
[ "$rc" = 3 ] || fail "the CI check of a stale bundle gave exit $rc, not 3"
if out=$(build); then fail "the failed bake was not retried: $out"; fi
echo "cmake-project: all checks passed"
