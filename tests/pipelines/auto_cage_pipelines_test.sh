#!/usr/bin/env bash
# Automatic cages in the pipelines (issue 43): fissure_add_bundle(... TETS N) and a
# Snakemake asset with `tets: N` bake without a cage file; a second run does nothing;
# changing the count re-bakes; CAGE and TETS together (or neither) is a clear error.
# Works in a temporary folder. Usage: auto_cage_pipelines_test.sh FISSURE_BAKE REPOSITORY_ROOT
set -euo pipefail
bake=$1 root=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
cp "$root/data/meshes/bunny-5k.obj" "$work/"

# CMake
mkdir -p "$work/cmake"
project() {
  cat >"$work/cmake/CMakeLists.txt" <<EOF
cmake_minimum_required(VERSION 3.20)
project(auto_cage NONE)
include("$root/pipelines/cmake/FissureBundles.cmake")
fissure_add_bundle(bunny MESH "$work/bunny-5k.obj" $1 OUTPUT bundles/bunny.h5 OPTIONS --skip walls collision ALL)
EOF
}
project "TETS 300"
cmake -S "$work/cmake" -B "$work/cmake/build" -G Ninja -DFISSURE_BAKE_EXECUTABLE="$bake" >/dev/null
out=$(cmake --build "$work/cmake/build" 2>&1) || fail "the CMake bake failed: $out"
grep -q "in an automatic cage of 300 tets" <<<"$out" || fail "no automatic cage: $out"
"$bake" status "$work/cmake/build/bundles/bunny.h5" --tets 300 --skip walls collision >/dev/null || fail "not up to date"
out=$(cmake --build "$work/cmake/build" 2>&1)
grep -q "no work to do" <<<"$out" || fail "a second build re-baked: $out"
project "TETS 400 METHOD lattice"
out=$(cmake --build "$work/cmake/build" 2>&1) || fail "the re-bake failed: $out"
grep -q "in an automatic cage of 400 tets" <<<"$out" || fail "a changed TETS did not re-bake: $out"
project "CAGE $root/data/cages/bunny-5k-cage-100.node TETS 300"
out=$(cmake "$work/cmake/build" 2>&1) && fail "CAGE and TETS together configured"
grep -q "give CAGE (a cage file) or TETS" <<<"$out" || fail "the error: $out"

# Snakemake
mkdir -p "$work/run"
manifest() {
  printf 'assets:\n  bunny:\n    mesh: %s\n%s    options: --skip walls collision\n' "$work/bunny-5k.obj" "$1" >"$work/assets.yaml"
}
run() {
  (cd "$work/run" && snakemake --snakefile "$root/pipelines/batch/Snakefile" --cores 2 \
    --config manifest="$work/assets.yaml" bake="$bake" 2>&1)
}
manifest $'    tets: 300\n'
out=$(run) || fail "the Snakemake bake failed: $out"
"$bake" inspect "$work/run/bundles/bunny.h5" | grep -q '"cage_tets":300' || fail "the bundle has no automatic cage"
out=$(run)
grep -q "Nothing to be done" <<<"$out" || fail "a second run re-baked: $out"
manifest $'    tets: 400\n    method: lattice\n'
out=$(run) || fail "the re-bake failed: $out"
"$bake" inspect "$work/run/bundles/bunny.h5" | grep -q '"cage_tets":400' || fail "a changed tets did not re-bake: $out"
manifest $'    tets: 300\n    cage: cage.node\n'
out=$(run) && fail "cage and tets together ran"
grep -q "needs a cage (a file) or tets" <<<"$out" || fail "the error: $out"
echo "automatic cages bake through CMake and Snakemake"
