#!/usr/bin/env bash
# Builds a preset (release by default) and runs every test of it with CTest.
# Usage: scripts/test.sh [release|debug|asan]
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
bash scripts/build.sh "$preset"
ctest --preset "$preset" --parallel "${FISSURE_JOBS:-$(nproc)}"
