#pragma once
// A 1x1 convolution (stride 1, no padding, one group) in 8-bit integers (int8_product.hpp):
// weights quantized once, per output channel, symmetric to +-127 (a scale each); the input
// quantized on every call, per image, to 0..127 over its own range (a scale and a zero point:
// dynamic quantization, no calibration); sums exact in 32 bits, then scaled back to float with
// the bias, and the activation after it applied to each stripe of columns while in cache.
// Outputs move by well under 1 % of their spread against the float product. Internal to
// keyfleet_vision (dnn_layers.cpp wraps it).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <cstdint>
#include <vector>

#include "avx2_product.hpp"

namespace keyfleet::vision {

class Int8PointwiseConvolution {
 public:
  // weights: output channels x input channels x 1 x 1, float; bias: empty or one per output.
  // The third argument (bfloat16, as the other product kernels take) is not used.
  Int8PointwiseConvolution(const cv::Mat& weights, const cv::Mat& bias, bool);

  int input_channels() const { return cin_; }
  int output_channels() const { return cout_; }
  bool bfloat16() const { return false; }

  // One image: src is input_channels planes of `pixels` floats, dst output_channels planes, each
  // set contiguous; `activation` may be null. Runs on cv::parallel_for_'s threads; not reentrant.
  void run(const float* src, int pixels, float* dst, const cv::dnn::ActivationLayer* activation);

 private:
  void pack(ProductBlock block);  // the weights for blocks of that shape

  int cin_, cout_, quads_;
  std::vector<std::int8_t> quantized_;  // [cout][cin]: the weights, once
  std::vector<float> bias_;             // padded to whole row blocks
  std::vector<float> weight_scale_;     // per output channel
  std::vector<float> weight_sum_;       // per output channel: the sum of its quantized weights
  ProductBlock block_{0, 0};
  int row_blocks_ = 0;
  std::vector<std::uint32_t> packed_;  // [row block][quad][block rows]
  std::vector<std::uint32_t> input_;   // [quad][columns]
  std::vector<float> scale_, offset_;  // per output channel, for this call's input
  std::vector<float> products_;        // when the blocks do not fill dst exactly
};

}  // namespace keyfleet::vision
