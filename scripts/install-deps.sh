#!/usr/bin/env bash
# Installs the Debian 12 packages Fissure needs to build, test and run.
# Idempotent: packages already present are skipped, so a second run is quick.
# python3-glad: generates the GL 4.5 core loader at build time; OSMesa and EGL (Mesa,
# llvmpipe) are the headless renderers; ffmpeg encodes `run --video`; GLFW and Dear
# ImGui (libimgui-dev) make `view`'s window and panel, and Xvfb lets its tests open a
# window without a display.
# clang and libclang-rt-14-dev (libFuzzer): the `fuzz` preset's targets (fuzz/).
# time (GNU time): scripts/fuzz-cli.py measures each run's peak memory with it.
# snakemake: the batch-baking workflow (pipelines/batch) and its test; python3-yaml: its
# manifests, and the CI examples' lint (tests/pipelines/ci_examples_test.py), which also
# runs shellcheck on their scripts (actionlint is not packaged for Debian 12).
# python3-matplotlib: the trade-study's plots (pipelines/tradeoffs) and its test.
# libopenblas0-serial: CHOLMOD's dense kernels; serial so that it neither fights TBB's
# threads nor changes results with the thread count (the reference BLAS is 3× slower).
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libassimp-dev libhdf5-dev hdf5-tools
  libcli11-dev libtbb-dev libtomlplusplus-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libglfw3-dev libimgui-dev xvfb xauth libosmesa6-dev libgl-dev libegl-dev libegl-mesa0 libgl1-mesa-dri python3-glad
  ffmpeg time
  clang libclang-rt-14-dev
  libssl-dev
  libsuitesparse-dev libopenblas0-serial
  libbullet-dev
  snakemake python3-yaml shellcheck python3-matplotlib
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
[ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
