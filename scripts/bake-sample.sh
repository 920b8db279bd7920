#!/usr/bin/env bash
# The main job on the bundled sample: bake the 5,000-triangle Stanford bunny into its
# 987-tet cage, then inspect and verify the bundle. Output: out/bunny-5k.h5.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh release --target fissure-bake
bake=build/release/bake/fissure-bake
mkdir -p out
"$bake" bake --mesh data/meshes/bunny-5k.obj --cage data/cages/bunny-5k-cage-987.node -o out/bunny-5k.h5
"$bake" inspect out/bunny-5k.h5
"$bake" verify out/bunny-5k.h5
echo "done: out/bunny-5k.h5 (inspect it with: $bake inspect out/bunny-5k.h5 --json, or h5dump -H)"
