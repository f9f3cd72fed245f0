#pragma once
// A 3x3 convolution with stride 1, padding 1 and one group (PP-OCR's and PlaceNet's dense 3x3
// layers): in float with 8 or more inputs and outputs by Winograd's F(4x4, 3x3)
// (winograd_3x3.hpp, 36 multiplications for 16 output pixels instead of 144), else (bfloat16, few
// channels) as one matrix product of nine taps over the input read in place: each plane gets a
// zero border, and output pixel (y, x) sums tap (ky, kx) of the input at (y + ky, x + kx) of the
// bordered plane, a fixed shift along its rows. Internal to keyfleet_vision (dnn_layers.cpp wraps
// it).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <cstdint>
#include <memory>
#include <vector>

#include "avx2_product.hpp"
#include "bf16_product.hpp"
#include "product_operands.hpp"
#include "winograd_3x3.hpp"

namespace keyfleet::vision {

class Convolution3x3 : public ProductKernel {
 public:
  // weights: output channels x input channels x 3 x 3, float; bias: empty or one per output;
  // bfloat16 as for SubpixelDeconvolution.
  // In float with 8 or more inputs and outputs the layer runs as Winograd's F(4x4, 3x3)
  // (winograd_3x3.hpp), else as nine taps of the product.
  Convolution3x3(const cv::Mat& weights, const cv::Mat& bias, bool bfloat16);

  // One image: src is input_channels planes of h x w, dst output_channels planes of h x w, each
  // set contiguous; `activation` (may be null) is applied to each output plane once written.
  // Runs on cv::parallel_for_'s threads. Not reentrant (work buffers).
  void run(const float* src, int h, int w, float* dst, const cv::dnn::ActivationLayer* activation);

 private:
  void pack(ProductBlock block);  // the weights for blocks of that shape
  void multiply(int block_begin, int block_end);

  std::unique_ptr<Winograd3x3> winograd_;  // where it pays
  ProductBlock block_{0, 0};
  int row_blocks_ = 0;
  PackedWeights packed_;
  // Per run: the bordered input, the products on the bordered width.
  int shifts_[9] = {};
  int columns_ = 0;
  ProductInput input_;
  std::vector<float> products_;
};

}  // namespace keyfleet::vision
