#pragma once
// The agent's text segmenter (selector.semantic in the agent's config), read by the vision
// library's make_text_segmenter. Its YAML description: semantic_config_yaml.hpp.
#include <string>

namespace keyfleet {

struct SemanticConfig {
  // ONNX text segmenter with its .json beside it; a relative path is also looked for in
  // <bin>/../share/keyfleet/models/. The default is PP-OCRv4's text detector at 256x192, tuned
  // to that size here (models/ppocr_tuned/, made by scripts/tune_detector.sh): on unseen real
  // photos it finds more text than the untuned detector at 288x224 or 320x256 for 0.76x and
  // 0.60x their multiply-adds (docs/results/2026-11-27-tuned-detector.md). Those two
  // (ppocr/ppocr_det_288x224.onnx, ppocr/ppocr_det_320x256.onnx: scripts/fetch_ppocr.sh) and
  // the MiniNet trained here (mininet_text.onnx, blind on real photos) are a line away.
  std::string model = "ppocr_det_256x192_tuned.onnx";
  double border = 0.1;  // border band, as a fraction of the mask's smaller side
  int threads = 1;      // OpenCV DNN threads
  // The product stand-ins in bfloat16 (float sums) where the CPU has AVX512-BF16; logits move by
  // ~0.01 on average, a few boundary pixels of a mask change. Off by default since the int8 1x1
  // layers and Winograd's F(4x4, 3x3) (float only): float with them took 0.92x bfloat16's time
  // a pass (docs/results/2026-11-27-int8-products.md). false: float.
  bool bfloat16 = false;
  // The wide 1x1 convolutions (64 or more channels in and out) in 8-bit integers on any AVX2 CPU
  // (DnnLayers::int8_pointwise), in place of float or bfloat16: PP-OCR's detector at 320x256 in
  // 0.93x the time of float, test_clean IoU unchanged (docs/results/2026-11-27-int8-products.md).
  bool int8 = true;
};

}  // namespace keyfleet
