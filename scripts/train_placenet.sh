#!/usr/bin/env bash
# The PlaceNet recipe (the station's holistic place descriptor), end to end, on this CPU: Debian
# packages, generated two-day streets, metric-learning training, ONNX export with OpenCV checks.
#   ./scripts/train_placenet.sh [WORK_DIR]        (default: build/placenet)
# Environment: STEPS (12000), KEYFLEET_DATA (street photos as facades where present), MODEL_OUT
# (WORK_DIR/placenet.onnx: the shipped models/placenet/placenet.onnx is replaced only by hand,
# after `keyfleet places eval`). Rerunning resumes: cached streets are kept, training continues
# from WORK_DIR/latest.pt; its curve is WORK_DIR/validation.csv.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-$root/build/placenet}
steps=${STEPS:-12000}
model_out=${MODEL_OUT:-$work/placenet.onnx}
data_root=${KEYFLEET_DATA:-$root/../shared/data}

"$root/scripts/install_deps.sh"  # python3-torch and the rest of the recipe's packages too
"$root/scripts/build.sh"
keyfleet="${KEYFLEET_BUILD_DIR:-$root/build}/bin/keyfleet"
[ -d "$data_root" ] || echo "train_placenet: no shared data at $data_root: procedural facades only"

mkdir -p "$work"
# Debian's python3 (torch lives there), not a pyenv one.
/usr/bin/python3 "$root/models/placenet/streets.py" --keyfleet "$keyfleet" --work "$work" \
  --data "$data_root"
/usr/bin/python3 "$root/models/placenet/train.py" --work "$work" --steps "$steps"
/usr/bin/python3 "$root/models/placenet/export.py" --checkpoint "$work/best.pt" \
  --out "$model_out" --work "$work"
echo "train_placenet: candidate $model_out (curve: $work/validation.csv); measure it with"
echo "  $keyfleet places eval --descriptor $model_out ...; ship it with"
echo "  cp $model_out ${model_out%.onnx}.json $root/models/placenet/"
