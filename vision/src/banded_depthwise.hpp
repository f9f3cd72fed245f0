#pragma once
// A layer and the depthwise convolution that is the only reader of its output, run a band of
// rows at a time: the first layer's rows for a band of the depthwise layer's output are computed
// (activated) into a buffer that stays in L2 and read there, instead of the whole output written
// to memory and read back. On PP-OCR's detector at 640x480 the 1x1 layer's output before its
// first stride-2 depthwise layer is 32 planes of 240x320, 9.8 MB, larger than the caches a shared
// core keeps: the depthwise layer took three times as long reading it from memory as from cache.
// Internal to keyfleet_vision (dnn_layers.cpp's 1x1 and stride-2 stand-ins fuse the depthwise
// layer through OpenCV's tryFuse).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <functional>
#include <vector>

namespace keyfleet::vision {

class BandedDepthwise {
 public:
  // The first layer's outputs worth it: from 2 MB an image (PP-OCR's detector at 640x480, one
  // thread, AVX2: its 1x1 layers' 9.8 MB output and the depthwise layer 0.68x the time, 3.7 MB
  // 0.93x, 1.8 MB 1.03x).
  static constexpr std::size_t kSmallestOutputBytes = std::size_t(2) << 20;

  // weights: channels x 1 x k x k float (k odd, padding k / 2 on every side, dilation 1);
  // bias: empty or one float a channel; stride: 1 or 2, along both axes.
  BandedDepthwise(const cv::Mat& weights, const cv::Mat& bias, int stride);

  // Whether a depthwise layer of these weights and geometry can be run so after a layer of
  // `channels` outputs (and this CPU runs depthwise_avx2.hpp).
  static bool takes(const cv::Mat& weights, const cv::Mat& bias, int channels, int kernel,
                    int stride, int pad_top, int pad_left, int pad_bottom, int pad_right,
                    int dilation_y, int dilation_x);

  int output_side(int side) const { return (side - 1) / stride_ + 1; }

  // Writes rows [first, last) of the first layer's output (activated) at `band`, its planes
  // `band_plane` floats apart.
  using Rows = std::function<void(int first, int last, float* band, std::size_t band_plane)>;

  // One image: the first layer's output is channels planes of h x w, given by `rows` a band at a
  // time; dst: channels planes of output_side(h) x output_side(w); `activation` (after the
  // depthwise layer) may be null. Not reentrant.
  void run(const Rows& rows, int h, int w, float* dst, const cv::dnn::ActivationLayer* activation);

 private:
  int channels_, kernel_, stride_;
  cv::Mat weights_;  // channels x (k k)
  std::vector<float> bias_;
  std::vector<float> band_;  // the first layer's output rows of the band, plane after plane
};

}  // namespace keyfleet::vision
