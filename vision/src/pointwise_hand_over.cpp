// The 1x1 convolution's hand-over to its readers (pointwise_hand_over.hpp): writing the waiting
// blob, the pooling's means, and the sum's epilogue.
#include "pointwise_hand_over.hpp"

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>

#include "dense_layers.hpp"
#include "upsampling_hand_over.hpp"

namespace keyfleet::vision {
namespace {

// d[i] = g d[i] + (a ? a[i] : 0), n floats.
void scale_add(float* d, float g, const float* a, int n) {
  int i = 0;
#if CV_SIMD
  constexpr int kLanes = cv::v_float32::nlanes;
  const cv::v_float32 vg = cv::vx_setall_f32(g);
  if (a)
    for (; i + kLanes <= n; i += kLanes)
      cv::v_store(d + i, cv::v_fma(vg, cv::vx_load(d + i), cv::vx_load(a + i)));
  else
    for (; i + kLanes <= n; i += kLanes) cv::v_store(d + i, vg * cv::vx_load(d + i));
#endif
  for (; i < n; ++i) d[i] = a ? g * d[i] + a[i] : g * d[i];
}

// d[i] = g d[i] + a[(x0 + i) / 2], n floats: each of a's columns twice.
void scale_add_doubled(float* d, float g, const float* a, int x0, int n) {
  int i = 0;
  if (x0 % 2 && n > 0) {
    d[0] = g * d[0] + a[x0 / 2];
    i = 1;
  }
#if CV_SIMD
  constexpr int kLanes = cv::v_float32::nlanes;
  const cv::v_float32 vg = cv::vx_setall_f32(g);
  for (; i + 2 * kLanes <= n; i += 2 * kLanes) {
    cv::v_float32 lo, hi;
    const cv::v_float32 v = cv::vx_load(a + (x0 + i) / 2);
    cv::v_zip(v, v, lo, hi);
    cv::v_store(d + i, cv::v_fma(vg, cv::vx_load(d + i), lo));
    cv::v_store(d + i + kLanes, cv::v_fma(vg, cv::vx_load(d + i + kLanes), hi));
  }
#endif
  for (; i < n; ++i) d[i] = g * d[i] + a[(x0 + i) / 2];
}

bool one_image_planes(const cv::Mat& m) { return planes_contiguous(m) && m.size[0] == 1; }

}  // namespace

void PointwiseHandOver::write_waiting() {
  if (!waiting()) return;
  CV_Assert(one_image_planes(target) && one_image_planes(source) && source.isContinuous());
  const ScaledSum sum(kernel->output_channels(), scales, cv::Mat(), target.size[3], 1, 1);
  const std::size_t plane = std::size_t(target.size[2]) * target.size[3];
  kernel->run_columns(source.ptr<float>(), plane, int(plane), target.ptr<float>(), plane, sum);
  target = cv::Mat();
}

void PointwiseHandOver::means(float* out) const {
  const int inputs = kernel->input_channels(), pixels = source.size[2] * source.size[3];
  std::vector<float> m(std::size_t(inputs), 0.f);
  for (int k = 0; k < inputs && pixels > 0; ++k)
    m[k] = plane_mean(source.ptr<float>() + std::size_t(k) * pixels, pixels);
  for (int c = 0; c < kernel->output_channels(); ++c) {
    const float* w = kernel->weights_of(c);
    float sum = kernel->bias_of(c);
    for (int k = 0; k < inputs; ++k) sum += w[k] * m[k];
    out[c] = scales.empty() ? sum : sum * scales[c];
  }
}

ScaledSum::ScaledSum(int channels, const std::vector<float>& scales, const cv::Mat& other,
                     int width, int ky, int kx)
    : channels_(channels), scales_(scales), other_(other), width_(width), ky_(ky), kx_(kx) {
  CV_Assert(scales_.empty() || int(scales_.size()) == channels_);
  CV_Assert(other_.empty() || (one_image_planes(other_) && other_.size[1] == channels_));
}

void ScaledSum::apply(float* out, std::size_t stride, int first, int n) const {
  if (other_.empty()) {
    for (int c = 0; c < channels_ && !scales_.empty(); ++c)
      scale_add(out + std::size_t(c) * stride, scales_[std::size_t(c)], nullptr, n);
    return;
  }
  thread_local std::vector<float> row;
  const int other_height = other_.size[2], other_width = other_.size[3];
  const std::size_t other_plane = std::size_t(other_height) * other_width;
  // A segment of one output row at a time, every channel; the other input's row read widened.
  for (int p = first; p < first + n;) {
    const int y = p / width_, x0 = p % width_;
    const int len = std::min(width_ - x0, first + n - p);
    const float* source_row = other_.ptr<float>() + std::size_t(y / ky_) * other_width;
    float* d = out + (p - first);
    for (int c = 0; c < channels_; ++c, d += stride, source_row += other_plane) {
      const float g = scales_.empty() ? 1.f : scales_[std::size_t(c)];
      if (kx_ == 1) {
        scale_add(d, g, source_row + x0, len);
      } else if (kx_ == 2) {
        scale_add_doubled(d, g, source_row, x0, len);
      } else {
        const int sx0 = x0 / kx_, sx1 = (x0 + len - 1) / kx_ + 1;
        row.resize(std::size_t(sx1 - sx0) * kx_);
        repeat_columns(source_row + sx0, sx1 - sx0, kx_, row.data());
        scale_add(d, g, row.data() + (x0 - sx0 * kx_), len);
      }
    }
    p += len;
  }
}

bool read_by_channel_scale(const std::vector<cv::Ptr<cv::dnn::Layer>>& readers) {
  for (const cv::Ptr<cv::dnn::Layer>& layer : readers)
    if (const auto* reader = dynamic_cast<const PointwiseReader*>(layer.get()))
      if (reader->scales_channels()) return true;
  return false;
}

bool hand_over_to(const std::vector<cv::Ptr<cv::dnn::Layer>>& readers,
                  const std::shared_ptr<PointwiseHandOver>& hand_over) {
  std::vector<PointwiseReader*> takers;
  for (const cv::Ptr<cv::dnn::Layer>& layer : readers)
    if (auto* reader = dynamic_cast<PointwiseReader*>(layer.get())) takers.push_back(reader);
  bool all = !readers.empty() && takers.size() == readers.size();
  for (PointwiseReader* reader : takers)
    if (all && !reader->read_pointwise(hand_over)) all = false;
  if (!all)
    for (PointwiseReader* reader : takers) reader->drop_pointwise(hand_over.get());
  return all;
}

void withdraw_from(const std::vector<cv::Ptr<cv::dnn::Layer>>& readers,
                   const PointwiseHandOver* hand_over) {
  for (const cv::Ptr<cv::dnn::Layer>& layer : readers)
    if (auto* reader = dynamic_cast<PointwiseReader*>(layer.get()))
      reader->drop_pointwise(hand_over);
}

void HeldHandOvers::add(const std::shared_ptr<PointwiseHandOver>& hand_over) {
  if (hand_over && std::find(held_.begin(), held_.end(), hand_over) == held_.end())
    held_.push_back(hand_over);
}

void HeldHandOvers::drop(const PointwiseHandOver* hand_over) {
  held_.erase(std::remove_if(held_.begin(), held_.end(),
                             [&](const auto& h) { return h.get() == hand_over; }),
              held_.end());
}

PointwiseHandOver* HeldHandOvers::waiting_as(const cv::Mat& blob) const {
  for (const auto& h : held_)
    if (h->is(blob)) return h.get();
  return nullptr;
}

}  // namespace keyfleet::vision
