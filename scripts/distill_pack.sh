#!/usr/bin/env bash
# Packs the sources a detector is distilled or tuned on into WORK_DIR/pack (generated streets,
# held-out ones, the ICDAR 2015 photos and unlabelled real frames, as WebP:
# models/mininet/distill_pack.py says which): scripts/distill_mininet.sh and
# scripts/tune_detector.sh run it. Each step is skipped where its `done` stamp is.
#   ./scripts/distill_pack.sh WORK_DIR        (needs the build's keyfleet and KEYFLEET_DATA)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${1:?usage: distill_pack.sh WORK_DIR}
data_root=${KEYFLEET_DATA:-$root/../shared/data}
keyfleet="${KEYFLEET_BUILD_DIR:-$root/build}/bin/keyfleet"
[ -x "$keyfleet" ] || { echo "distill_pack: no $keyfleet (scripts/build.sh)" >&2; exit 1; }
[ -d "$data_root/icdar2015/train/images" ] ||
  { echo "distill_pack: no ICDAR 2015 photos under $data_root (KEYFLEET_DATA)" >&2; exit 1; }

mkdir -p "$work"
if [ ! -f "$work/pairs/done" ]; then
  rm -rf "$work/pairs"
  "$keyfleet" scenario training "$root/configs/scenario_training.yaml" --out "$work/pairs" --count 600
  touch "$work/pairs/done"
fi
if [ ! -f "$work/heldout/done" ]; then  # other streets (another seed), as train_mininet.sh's
  rm -rf "$work/heldout"
  "$keyfleet" scenario training "$root/configs/scenario_training.yaml" --seed 977 \
    --out "$work/heldout" --count 100
  touch "$work/heldout/done"
fi
if [ ! -f "$work/pack/done" ]; then
  rm -rf "$work/pack"
  /usr/bin/python3 "$root/models/mininet/distill_pack.py" --data "$data_root" \
    --generated "$work/pairs" --heldout "$work/heldout" --out "$work/pack"
  touch "$work/pack/done"
fi
