#!/usr/bin/env bash
# The shipped place-recognition vocabulary (models/vocabulary/orb_vocabulary.bin), rebuilt:
# a street scenario generated with seed 5 (the demo flies seed 7, so the vocabulary never saw
# the demo's frames), 300 of its 1800 frames evenly spread, 1000 ORB features each,
# k = 10, L = 4, k-means++ seed 1.
#   ./scripts/build_vocabulary.sh [OUT_FILE] [WORK_DIR]
# Same scenario -> same file, byte for byte. The scenario takes its facade photos from
# ../shared/data when present (KEYFLEET_DATA), procedural ones otherwise: the two give
# different (equally valid) vocabularies.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$root/models/vocabulary/orb_vocabulary.bin}
work=${2:-$root/build/vocabulary}
keyfleet="${KEYFLEET_BUILD_DIR:-$root/build}/bin/keyfleet"
[ -x "$keyfleet" ] || "$root/scripts/build.sh"

mkdir -p "$work" "$(dirname "$out")"
if [ ! -f "$work/scenario/done" ]; then
  rm -rf "$work/scenario"
  sed 's/^seed: .*/seed: 5/' "$root/configs/scenario_small.yaml" > "$work/scenario.yaml"
  "$keyfleet" scenario generate "$work/scenario.yaml" --out "$work/scenario"
  touch "$work/scenario/done"
fi
time "$keyfleet" vocabulary build --images "$work/scenario" --out "$out" \
  --max-images 300 --features 1000 --branching 10 --depth 4 --seed 1
"$keyfleet" vocabulary info "$out"
