#!/usr/bin/env bash
# pipelines/examples/find-package-project from an installed prefix (issue 45): `cmake
# --install` of this build, then the example configured with CMAKE_PREFIX_PATH only
# (find_package(Fissure 0.1) finds the package and its version file, and the
# fissure-bake installed beside it), built (the bundle is baked and verified) and
# installed. A version of another major is refused by name. Before issue 45 there was
# no version file: find_package(Fissure 0.1) failed with "version: unknown".
# Usage: find_package_test.sh BUILD_DIR REPOSITORY_ROOT
set -euo pipefail
build=$1 root=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$work/prefix" >/dev/null
[ -x "$work/prefix/bin/fissure-bake" ] || fail "the install has no bin/fissure-bake"
[ -f "$work/prefix/lib/cmake/Fissure/FissureConfigVersion.cmake" ] || fail "the install has no FissureConfigVersion.cmake"

# The consumer sees only the prefix: no fissure-bake on the PATH, no Fissure source.
cp -r "$root/pipelines/examples/find-package-project" "$work/game"
out=$(env PATH=/usr/bin:/bin cmake -S "$work/game" -B "$work/build" -G Ninja -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DGAME_ASSETS="$root/data" 2>&1) || fail "configuring the consumer failed: $out"
grep -q -- "-- Fissure 0.1.0: $work/prefix/bin/fissure-bake" <<<"$out" || fail "not the installed fissure-bake: $out"
out=$(cmake --build "$work/build" 2>&1) || fail "building the consumer failed: $out"
grep -q "bundles/bunny.h5: all invariants hold" <<<"$out" || fail "the bundle was not verified under its own name: $out"
if grep -q "building.h5" <<<"$out"; then fail "the build log names the temporary: $out"; fi
"$work/prefix/bin/fissure-bake" status "$work/build/bundles/bunny.h5" >/dev/null || fail "the consumer's bundle is stale"
cmake --install "$work/build" --prefix "$work/game-install" >/dev/null
[ -f "$work/game-install/share/game/bundles/bunny.h5" ] || fail "the bundle was not installed with the game"

# Another major version is refused, naming the version found.
sed -i 's/find_package(Fissure 0.1 REQUIRED)/find_package(Fissure 1.0 REQUIRED)/' "$work/game/CMakeLists.txt"
if out=$(cmake -S "$work/game" -B "$work/build-1" -DCMAKE_PREFIX_PATH="$work/prefix" -DGAME_ASSETS="$root/data" 2>&1); then
  fail "find_package(Fissure 1.0) accepted 0.1.0: $out"
fi
grep -q "0.1.0" <<<"$out" || fail "the refusal does not name the version found: $out"
echo "find_package consumer: all checks passed"
