#include "upsampled_concatenation.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>

namespace keyfleet::vision {

UpsampledConcatenation::UpsampledConcatenation(const cv::Mat& weights, const cv::Mat& bias)
    : weights_(weights.isContinuous() ? weights : weights.clone()), bias_(bias) {
  CV_Assert(weights_.dims == 4 && weights_.type() == CV_32F && weights_.size[2] == 3 &&
            weights_.size[3] == 3);
}

bool UpsampledConcatenation::waiting() const {
  return std::any_of(hand_overs_.begin(), hand_overs_.end(),
                     [](const auto& h) { return h->waiting(); });
}

void UpsampledConcatenation::write_waiting() {
  for (const auto& hand_over : hand_overs_)
    if (hand_over->waiting()) {
      upsample_nearest(hand_over->source, hand_over->target);
      hand_over->target = cv::Mat();
    }
}

UpsampledTaps& UpsampledConcatenation::taps_for(int first, int channels) {
  for (const auto& taps : taps_)
    if (taps->first() == first && taps->channels() == channels) return *taps;
  taps_.push_back(std::make_unique<UpsampledTaps>(weights_, first, channels));
  return *taps_.back();
}

Winograd3x3& UpsampledConcatenation::winograd_for(int first, int channels) {
  if (!winograd_ || winograd_first_ != first || winograd_channels_ != channels) {
    const cv::Range all = cv::Range::all(), taken(first, first + channels);
    const cv::Range ranges[4] = {all, taken, all, all};
    winograd_ = std::make_unique<Winograd3x3>(weights_(ranges).clone(), bias_);
    winograd_first_ = first;
    winograd_channels_ = channels;
  }
  return *winograd_;
}

bool UpsampledConcatenation::run(const cv::Mat& in, float* out,
                                 const cv::dnn::ActivationLayer* activation) {
  const int inputs = weights_.size[1], outputs = weights_.size[0];
  if (in.dims != 4 || in.size[0] != 1 || in.size[1] != inputs || !in.isContinuous() ||
      outputs < 8)  // Winograd's product where it pays, as Convolution3x3 has it
    return false;
  const int h = in.size[2], w = in.size[3];
  const std::size_t plane = std::size_t(h) * w, plane_bytes = plane * sizeof(float);
  const auto* begin = in.data;
  const auto* end = in.data + in.total() * in.elemSize();
  std::vector<Slice> slices;
  for (const auto& hand_over : hand_overs_) {
    if (!hand_over->waiting()) continue;
    const cv::Mat& source = hand_over->source;
    const cv::Mat& target = hand_over->target;
    if (target.dims != 4 || target.size[0] != 1 || target.size[2] != h || target.size[3] != w ||
        target.data < begin || target.data + target.size[1] * plane_bytes > end ||
        std::size_t(target.data - begin) % plane_bytes != 0 || source.dims != 4 ||
        source.type() != CV_32F || !source.isContinuous() || source.size[1] != target.size[1] ||
        source.size[2] <= 0 || source.size[3] <= 0 || h % source.size[2] != 0 ||
        w % source.size[3] != 0 || h / source.size[2] < 2 || w / source.size[3] < 2)
      return false;
    slices.push_back({hand_over.get(), int(std::size_t(target.data - begin) / plane_bytes),
                      target.size[1], h / source.size[2], w / source.size[3]});
  }
  if (slices.empty()) return false;
  // The channels written in place: one run, what the slices leave.
  std::vector<bool> handed(std::size_t(inputs), false);
  for (const Slice& s : slices)
    for (int c = s.first; c < s.first + s.channels; ++c) {
      if (handed[std::size_t(c)]) return false;  // two slices over one channel
      handed[std::size_t(c)] = true;
    }
  const auto first = std::find(handed.begin(), handed.end(), false);
  const auto last = std::find(first, handed.end(), true);
  if (std::find(last, handed.end(), false) != handed.end() || last - first < 8) return false;
  const int kept_first = int(first - handed.begin()), kept = int(last - first);

  winograd_for(kept_first, kept).run(in.ptr<float>() + kept_first * plane, h, w, out, nullptr);
  std::vector<UpsampledTaps*> taps;
  for (const Slice& s : slices) {
    taps.push_back(&taps_for(s.first, s.channels));
    const cv::Mat& source = s.hand_over->source;
    taps.back()->multiply(source.ptr<float>(), source.size[2], source.size[3]);
  }
  cv::parallel_for_(cv::Range(0, outputs), [&](const cv::Range& range) {
    for (int o = range.start; o < range.end; ++o) {
      float* dst = out + std::size_t(o) * plane;
      for (std::size_t i = 0; i < slices.size(); ++i)
        taps[i]->add_to(o, slices[i].ky, slices[i].kx, dst);
      if (activation) activation->forwardSlice(dst, dst, int(plane), plane, o, o + 1);
    }
  });
  for (const Slice& s : slices) s.hand_over->target = cv::Mat();
  return true;
}

}  // namespace keyfleet::vision
