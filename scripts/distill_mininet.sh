#!/usr/bin/env bash
# Distils PP-OCRv4's detector (the agent's semantic model) into MiniNet students, end to end:
# Debian packages, the teacher (scripts/fetch_ppocr.sh), generated streets, the packed sources
# (models/mininet/distill_pack.py), training (models/mininet/distill.py), export and Table III.
#   ./scripts/distill_mininet.sh [WORK_DIR]        (default: build/distill)
# Environment: DEVICE (cpu; cuda where a GPU is lent), STUDENTS (width multipliers, 0.5),
# STEPS (20000), MAX_MINUTES (0: no limit), BATCH (32), LR (3e-3), INIT (the shipped 2-class
# MiniNet for a width-1.0 student; empty: from scratch), KEYFLEET_DATA.
# A lent GPU reaches none of the data: run the steps up to the pack here, carry WORK_DIR/pack and
# the teacher there, run distill.py there and bring the checkpoints back (EXPORT_FROM=CHECKPOINT
# skips training and exports that one). What two GPU runs gave and what is still missing:
# docs/results/2026-11-27-distillation.md. The shipped models are replaced only by hand.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-$root/build/distill}
data_root=${KEYFLEET_DATA:-$root/../shared/data}
build=${KEYFLEET_BUILD_DIR:-$root/build}
students=${STUDENTS:-0.5}
width=${students%%,*}

"$root/scripts/install_deps.sh"
"$root/scripts/build.sh"
"$root/scripts/fetch_ppocr.sh"
keyfleet="$build/bin/keyfleet"
teacher="$build/share/keyfleet/models/ppocr/ppocr_det_320x256.onnx"
[ -f "$teacher" ] || { echo "distill_mininet: no teacher at $teacher (fetch_ppocr.sh)" >&2; exit 1; }
"$root/scripts/distill_pack.sh" "$work"
checkpoint=${EXPORT_FROM:-}
if [ -z "$checkpoint" ]; then
  init=()
  [ -n "${INIT:-}" ] && init=(--init "$INIT")
  (cd "$root/models/mininet" && /usr/bin/python3 distill.py --pack "$work/pack" \
    --teacher "$teacher" --work "$work/train" --students "$students" --device "${DEVICE:-cpu}" \
    --steps "${STEPS:-20000}" --max-minutes "${MAX_MINUTES:-0}" --batch "${BATCH:-32}" \
    --lr "${LR:-3e-3}" "${init[@]}")
  checkpoint="$work/train/student_w${width}_best.pt"
fi
model_out="$work/mininet_distilled_w${width}.onnx"
(cd "$root/models/mininet" && /usr/bin/python3 export.py --checkpoint "$checkpoint" \
  --out "$model_out" --input-width 320 --input-height 256 \
  --training-data "distilled from PP-OCRv4's detector on $work/pack")
"$keyfleet" segmenter eval --model "$model_out" --compare ppocr/ppocr_det_320x256.onnx \
  --generated "$work/heldout" --data "$data_root" --sizes 320x256
echo "distill_mininet: candidate $model_out (curve: $work/train/validation.csv)"
