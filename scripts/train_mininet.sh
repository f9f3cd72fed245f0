#!/usr/bin/env bash
# The MiniNet recipe, end to end, on this CPU: Debian packages, training data from the
# scenario generator, training, ONNX export with OpenCV checks, evaluation table.
#   ./scripts/train_mininet.sh [WORK_DIR]        (default: build/mininet)
# Environment: STEPS (12000), PAIRS (3000 generated image + mask pairs), KEYFLEET_DATA,
# MODEL_OUT (WORK_DIR/mininet_text.onnx: the shipped models/mininet/mininet_text.onnx is replaced
# only by hand, after a full evaluation of the candidate).
# With ../shared/data, street photos become facades, the 1000 ICDAR 2015 training photos join the
# training (every 10th image id held out as the validation that picks best.pt) and so do the
# test_blurred photos after the evaluation's first 100; without it, generated views only (best.pt
# by generated validation; ICDAR rows of the evaluation are then skipped). Training resumes from
# WORK_DIR/train/latest.pt when rerun; its curve is WORK_DIR/train/validation.csv.
# INIT=MODEL.onnx fine-tunes an exported model instead of training from scratch, the way the
# real-photo candidate was made from the shipped model (docs/results/2026-11-24-semantic-model.md): lr 3e-4, half
# of each batch ICDAR train, 8000 steps (STEPS's default then), seed 3, the last checkpoint
# exported (the validation split's 150 generated views did not predict held-out streets between
# checkpoints). ICDAR_SCALE (default 0.5) is the scale the photos are loaded at before cropping.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-$root/build/mininet}
init=${INIT:-}
steps=${STEPS:-$([ -n "$init" ] && echo 8000 || echo 12000)}
pairs=${PAIRS:-3000}
model_out=${MODEL_OUT:-$work/mininet_text.onnx}
data_root=${KEYFLEET_DATA:-$root/../shared/data}

"$root/scripts/install_deps.sh"  # python3-torch and the rest of the recipe's packages too
"$root/scripts/build.sh"
keyfleet="${KEYFLEET_BUILD_DIR:-$root/build}/bin/keyfleet"
[ -d "$data_root" ] || echo "train_mininet: no shared data at $data_root: procedural facades only"

mkdir -p "$work"
if [ ! -f "$work/pairs/done" ]; then
  rm -rf "$work/pairs"
  "$keyfleet" scenario training "$root/configs/scenario_training.yaml" --out "$work/pairs" --count "$pairs"
  touch "$work/pairs/done"
fi
if [ ! -f "$work/heldout/done" ]; then  # other streets (another seed) for the evaluation
  rm -rf "$work/heldout"
  "$keyfleet" scenario training "$root/configs/scenario_training.yaml" --seed 977 \
    --out "$work/heldout" --count 200
  touch "$work/heldout/done"
fi
# Debian's python3 (torch lives there), not a pyenv one.
real_photos=()
trained_on="$pairs pairs of configs/scenario_training.yaml"
if [ -d "$data_root/icdar2015/train/images" ]; then
  real_photos+=(--icdar-train "$data_root/icdar2015/train")
  trained_on="$trained_on + ICDAR 2015 train (900 photos; ids divisible by 10 validate)"
fi
if [ -d "$data_root/icdar2015/test_blurred" ]; then
  real_photos+=(--icdar "$data_root")
  trained_on="$trained_on + ICDAR 2015 test_blurred img_201..500"
fi
recipe=(--steps "$steps" --icdar-scale "${ICDAR_SCALE:-0.5}")
checkpoint=best.pt
if [ -n "$init" ]; then
  recipe+=(--init "$init" --lr 3e-4 --mix 3,4,1 --seed 3)
  checkpoint=latest.pt
  trained_on="fine-tuned from $(basename "$init") on $trained_on"
fi
/usr/bin/python3 "$root/models/mininet/train.py" --data "$work/pairs" --work "$work/train" \
  --workers 1 "${recipe[@]}" "${real_photos[@]}"
/usr/bin/python3 "$root/models/mininet/export.py" --checkpoint "$work/train/$checkpoint" \
  --out "$model_out" --input-width 320 --input-height 256 \
  --training-data "$trained_on, $steps steps, checkpoint $checkpoint"
"$keyfleet" segmenter eval --model "$model_out" --generated "$work/heldout" --data "$data_root"
echo "train_mininet: candidate $model_out (curve: $work/train/validation.csv); ship it with"
echo "  cp $model_out ${model_out%.onnx}.json $root/models/mininet/  (after the full evaluation)"
