#pragma once
// A 1x1 convolution and the depthwise convolution that is the only reader of its output, run a
// band of rows at a time: the 1x1 layer's rows for a band of the depthwise layer's output are
// computed (activated) into a buffer that stays in L2 and read there, instead of the whole output
// written to memory and read back. On PP-OCR's detector at 640x480 that output is 32 planes of
// 240x320, 9.8 MB, larger than the caches a shared core keeps: the depthwise layer after it took
// three times as long reading it from memory as from cache. Internal to keyfleet_vision
// (dnn_layers.cpp's 1x1 stand-in fuses the depthwise layer through OpenCV's tryFuse).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <vector>

#include "pointwise_convolution.hpp"

namespace keyfleet::vision {

class BandedDepthwise {
 public:
  // The 1x1 layer's outputs worth it: from 2 MB (PP-OCR's detector at 640x480, one thread, AVX2:
  // its 9.8 MB output and the depthwise layer 0.68x the time, 3.7 MB 0.93x, 1.8 MB 1.03x).
  static constexpr std::size_t kSmallestOutputBytes = std::size_t(2) << 20;

  // weights: channels x 1 x k x k float (k odd, padding k / 2 on every side, dilation 1);
  // bias: empty or one float a channel; stride: 1 or 2, along both axes.
  BandedDepthwise(const cv::Mat& weights, const cv::Mat& bias, int stride);

  // Whether a depthwise layer of these weights and geometry can be run so after a 1x1 layer of
  // `channels` outputs (and this CPU runs depthwise_avx2.hpp).
  static bool takes(const cv::Mat& weights, const cv::Mat& bias, int channels, int kernel,
                    int stride, int pad_top, int pad_left, int pad_bottom, int pad_right,
                    int dilation_y, int dilation_x);

  int output_side(int side) const { return (side - 1) / stride_ + 1; }

  // One image: src (the 1x1 layer's input planes of h x w), dst (channels planes of
  // output_side(h) x output_side(w)); each activation may be null: `pointwise_activation` after
  // the 1x1 layer, `activation` after the depthwise one. Not reentrant.
  void run(PointwiseConvolution& pointwise, const cv::dnn::ActivationLayer* pointwise_activation,
           const float* src, int h, int w, float* dst, const cv::dnn::ActivationLayer* activation);

 private:
  int channels_, kernel_, stride_;
  cv::Mat weights_;  // channels x (k k)
  std::vector<float> bias_;
  std::vector<float> band_;  // the 1x1 layer's output rows of the band, plane after plane
};

}  // namespace keyfleet::vision
