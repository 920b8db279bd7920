#!/usr/bin/env bash
# Remakes docs/images/bunny-drop.png, the README's picture: four frames of the sample run
# (scripts/bake-sample.sh writes them) side by side, a quarter of their size. Needs ffmpeg.
set -euo pipefail
cd "$(dirname "$0")/.."
frames=out/bunny-drop-frames
for f in 00000 00017 00030 00060; do
  [ -f "$frames/frame-$f.png" ] || { echo "error: $frames/frame-$f.png is missing; run scripts/bake-sample.sh first" >&2; exit 1; }
done
mkdir -p docs/images
ffmpeg -loglevel error -y \
  -i "$frames/frame-00000.png" -i "$frames/frame-00017.png" -i "$frames/frame-00030.png" -i "$frames/frame-00060.png" \
  -filter_complex "[0]scale=320:-1[a];[1]scale=320:-1[b];[2]scale=320:-1[c];[3]scale=320:-1[d];[a][b][c][d]hstack=inputs=4" \
  docs/images/bunny-drop.png
echo "docs/images/bunny-drop.png"
