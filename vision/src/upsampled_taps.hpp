#pragma once
// A 3x3 convolution's share from channels that are a nearest upsampling by ky x kx (both 2 or
// more) of a smaller map (PP-OCR's DB head reads the FPN's levels upsampled by 8, 4 and 2 and
// concatenated): computed at the small map's size. Output row y = sy * ky + r reads source row
// sy through all three taps of a column except at the block's edges (r = 0: tap -1 reads sy - 1;
// r = ky - 1: tap +1 reads sy + 1); columns alike. So the nine taps' products of each source
// pixel (a matrix product at the small size: 9 x outputs x channels x h x w multiply-adds, 1/64
// of the direct sum's at ky = kx = 8, 1/16 at 4) summed by rows and columns make each output row
// of a block row's class (top, middle, bottom) once; its pixels then add that row. The direct
// sum's values up to float rounding (another order of additions). Float, x86-64 with AVX2 and
// FMA (product_supported()); internal to keyfleet_vision (convolution_layers.cpp uses it).
#include <opencv2/core.hpp>

#include <vector>

#include "avx2_product.hpp"

namespace keyfleet::vision {

class UpsampledTaps {
 public:
  // weights: the convolution's, outputs x inputs x 3 x 3, float; this share reads its input
  // channels [first, first + channels).
  UpsampledTaps(const cv::Mat& weights, int first, int channels);

  // The nine taps' products of `source` (channels planes of h x w, contiguous): once a pass,
  // before add_to(). Runs on cv::parallel_for_'s threads.
  void multiply(const float* source, int h, int w);

  // Adds this share to output plane `output` (h * ky rows of w * kx floats, contiguous) of
  // the source multiplied last. Other outputs may be added at the same time on other threads.
  void add_to(int output, int ky, int kx, float* plane) const;

  int first() const { return first_; }
  int channels() const { return channels_; }

 private:
  int outputs_, first_, channels_;
  std::vector<float> weights_;  // [9 * outputs][channels], row = tap * outputs + output
  ProductBlock block_{0, 0};
  std::vector<float> packed_;  // per block of rows: [channels][block rows], row = tap * outputs + o
  std::vector<float> zeros_;   // the product's bias
  // Per pass: the source padded to whole column blocks, and its products [9 * outputs][stride].
  int h_ = 0, w_ = 0, stride_ = 0;
  std::vector<float> source_, products_;
};

}  // namespace keyfleet::vision
