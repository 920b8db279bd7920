#!/usr/bin/env bash
# Installs the dependencies (idempotent), configures and builds one CMake preset.
# Usage: scripts/build.sh [release|debug|asan] [cmake --build args, e.g. --target fissure-bake]
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
shift || true
if [ "${FISSURE_SKIP_INSTALL:-0}" != "1" ]; then
  bash scripts/install-deps.sh
fi
jobs="${FISSURE_JOBS:-$(nproc)}"
# Let ccache reuse objects across clones in different directories (CI clones afresh).
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" --parallel "$jobs" "$@"
