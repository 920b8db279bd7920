#!/usr/bin/env bash
# The main job on the bundled sample: bake the 5,000-triangle Stanford bunny into its
# 987-tet cage, inspect and verify the bundle, then play data/scenes/bunny-drop.toml
# headless (the bunny drops, a ball hits it, it cracks).
# Outputs: out/bunny-5k.h5, out/bunny-drop-report.json (timings and summary),
# out/bunny-drop-trajectory.h5 (node positions and fracture events).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh release --target fissure-bake fissure-player
bake=build/release/bake/fissure-bake
# OpenBLAS (inside CHOLMOD) picks its kernel by CPU, and the kernel changes rounding, so
# fracture can differ in detail between machines: with the Haswell kernels, which any
# AVX2 machine runs, the figures match the README's (docs/reproducibility.md).
if grep -qw avx2 /proc/cpuinfo 2>/dev/null && grep -qw fma /proc/cpuinfo && [ -z "${OPENBLAS_CORETYPE:-}" ]; then
  export OPENBLAS_CORETYPE=Haswell
fi
mkdir -p out
"$bake" bake --mesh data/meshes/bunny-5k.obj --cage data/cages/bunny-5k-cage-987.node -o out/bunny-5k.h5
"$bake" inspect out/bunny-5k.h5
"$bake" verify out/bunny-5k.h5
build/release/player/app/fissure-player run data/scenes/bunny-drop.toml --no-render --steps 480 \
  --report out/bunny-drop-report.json --trajectory out/bunny-drop-trajectory.h5 --trajectory-every 4
echo "done: out/bunny-5k.h5, out/bunny-drop-report.json, out/bunny-drop-trajectory.h5"
echo "(inspect the bundle with: $bake inspect out/bunny-5k.h5 --json, or h5dump -H)"
