#pragma once
// A dense k x k convolution with stride 2 and few input channels (a network's first layer: PP-OCR's
// 3 -> 16 3x3 at full resolution) as one matrix product: the k x k x inputs values each output
// pixel reads are laid out as that many planes (each input row's even and odd columns split once,
// so every tap is a run of consecutive floats), then multiplied by the weights by the 1x1 kernel
// (pointwise_convolution.hpp), the activation after it applied as its stripes are done. OpenCV
// 4.6's general convolution spends most of such a layer arranging its few inputs. Float only;
// AVX2 and FMA (the caller checks). Internal to keyfleet_vision (dnn_layers.cpp wraps it).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <vector>

#include "pointwise_convolution.hpp"

namespace keyfleet::vision {

class StridedConvolution {
 public:
  // weights: outputs x inputs x k x k, float; bias: empty or one per output; `pad` on every side.
  StridedConvolution(const cv::Mat& weights, const cv::Mat& bias, int pad);

  int input_channels() const { return cin_; }
  int output_channels() const { return product_.output_channels(); }
  // The output's side for an input side of n.
  int output_side(int n) const { return (n + 2 * pad_ - k_) / 2 + 1; }

  // One image: src is input_channels planes of h x w, dst output_channels planes of
  // output_side(h) x output_side(w); `activation` may be null. Not reentrant.
  void run(const float* src, int h, int w, float* dst, const cv::dnn::ActivationLayer* activation);
  // Output rows [y0, y1) only, into dst (row y0 of each plane; planes `dst_plane` floats apart).
  void run_rows(const float* src, int h, int w, int y0, int y1, float* dst, std::size_t dst_plane,
                const cv::dnn::ActivationLayer* activation);

 private:
  int cin_, k_, pad_;
  PointwiseConvolution product_;                 // over cin x k x k "channels"
  static constexpr int kBandFloats = 64 * 1024;  // of those planes at a time (256 KB)
  std::vector<float> columns_;                   // those planes, for a band of output rows
  std::vector<float> products_;                  // the band's outputs
  std::vector<float> row_, even_, odd_;
};

}  // namespace keyfleet::vision
