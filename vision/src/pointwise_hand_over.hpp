#pragma once
// A float 1x1 convolution whose output x only stand-ins that know this hand-over read, PP-OCR's
// RSE layers in its FPN: x (96 channels, 7.4 MB at 640x480 for the largest level) is read by a
// global average pooling (the squeeze-and-excitation's squeeze) and by a channel scaling x * g
// (g its gate plus one, models/ppocr/convert_ppocr.py), whose output y only an element-wise sum
// reads (y + up(the level above)). The convolution leaves x unwritten and hands over a copy of its
// input m (12 channels there); the pooling takes x's means from m's (mean(W m + b) = W mean(m)
// + b: the same to float rounding); the scaling notes g and leaves y unwritten in turn; and the
// sum computes g (W m + b) + up(...) a stripe of columns at a time as the 1x1 kernel's epilogue,
// x and y never written nor read back (the finest level at 640x480: four layers' 1.4 ms on one
// core in one pass of 0.9, docs/results/2026-11-29-excited-sums.md). Each reader checks the
// hand-over against its input on every pass; one that cannot take it writes the waiting blob first
// (write_waiting), as unfused. Internal to keyfleet_vision (convolution_layers.cpp,
// dense_layers.cpp, channel_scale.cpp, elementwise_sum.cpp).
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include <memory>
#include <vector>

#include "pointwise_convolution.hpp"

namespace keyfleet::vision {

struct PointwiseHandOver {
  PointwiseConvolution* kernel = nullptr;  // the convolution's (float, runs_columns()); its layer's
  cv::Mat source;                          // a copy of its input (one image)
  std::vector<float> scales;               // per output channel, once a scaling took it; else empty
  cv::Mat target;  // the blob left unwritten (x, then y); empty when nothing waits
  bool waiting() const { return !target.empty(); }
  // Whether `blob` is the one left unwritten.
  bool is(const cv::Mat& blob) const { return waiting() && blob.data == target.data; }
  // Writes the waiting blob (the kernel on the source, scaled) and clears the hand-over.
  void write_waiting();
  // Each output channel's mean over the source's pixels, scaled: what a global average pooling
  // of the waiting blob gives.
  void means(float* out) const;
};

// The sum's epilogue (and the scaling's where it writes its output itself): channel c of a
// stripe, out = scales[c] out + other's pixel (scales empty: 1; other empty: nothing added).
// `other`: empty, or one image of `channels` planes whose rows and columns, repeated ky and kx
// times, make the output's (of `width` columns).
class ScaledSum final : public ColumnsEpilogue {
 public:
  ScaledSum(int channels, const std::vector<float>& scales, const cv::Mat& other, int width, int ky,
            int kx);
  void apply(float* out, std::size_t stride, int first, int n) const override;

 private:
  int channels_;
  const std::vector<float>& scales_;
  cv::Mat other_;
  int width_, ky_, kx_;
};

// A stand-in that reads the convolution's (or the scaling's) output. Each convolution hands over
// one object of its own, the same at every set-up: a reader keeps every one it takes (a sum may
// read two convolutions) and forgets only the one it is told to.
class PointwiseReader {
 public:
  virtual ~PointwiseReader() = default;
  // Whether it takes `hand_over` (it then checks it on every pass); taking one twice is once.
  virtual bool read_pointwise(const std::shared_ptr<PointwiseHandOver>& hand_over) = 0;
  virtual void drop_pointwise(const PointwiseHandOver* hand_over) = 0;
  // The channel scaling (the pattern measured; a 1x1 layer whose only reader is a sum, say
  // MiniNet's residual blocks with an activation fused into the sum, would gain nothing).
  virtual bool scales_channels() const { return false; }
};

// What a reader holds.
class HeldHandOvers {
 public:
  void add(const std::shared_ptr<PointwiseHandOver>& hand_over);
  void drop(const PointwiseHandOver* hand_over);
  // The one whose waiting blob is `blob`, else null.
  PointwiseHandOver* waiting_as(const cv::Mat& blob) const;
  const std::vector<std::shared_ptr<PointwiseHandOver>>& all() const { return held_; }

 private:
  std::vector<std::shared_ptr<PointwiseHandOver>> held_;
};

// Whether one of `readers` is a channel scaling that takes hand-overs.
bool read_by_channel_scale(const std::vector<cv::Ptr<cv::dnn::Layer>>& readers);

// At set-up: hands `hand_over` to every one of `readers` (a layer's output's, fusion_order.hpp)
// where each is a PointwiseReader that takes it; else to none (those that took it drop it).
// Whether it was handed over.
bool hand_over_to(const std::vector<cv::Ptr<cv::dnn::Layer>>& readers,
                  const std::shared_ptr<PointwiseHandOver>& hand_over);
// Tells every PointwiseReader of `readers` to forget `hand_over` (not handed over this set-up).
void withdraw_from(const std::vector<cv::Ptr<cv::dnn::Layer>>& readers,
                   const PointwiseHandOver* hand_over);

}  // namespace keyfleet::vision
