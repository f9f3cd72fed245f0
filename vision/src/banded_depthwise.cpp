#include "banded_depthwise.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>

#include "depthwise_avx2.hpp"

namespace keyfleet::vision {
namespace {

// The band's buffer of the first layer's rows: half of a small L2 (Zen 3's 512 KB), so that the
// input rows it reads and the weights stay beside it. PP-OCR's 16 -> 32 then 3x3 stride 2 at
// 640x480 (one thread, AVX2): 1.85 ms with 256 KB, 1.75 with 512, 2.0 with 64 (unbanded 2.7).
constexpr std::size_t kBandBytes = std::size_t(256) << 10;

}  // namespace

BandedDepthwise::BandedDepthwise(const cv::Mat& weights, const cv::Mat& bias, int stride)
    : channels_(weights.size[0]),
      kernel_(weights.size[2]),
      stride_(stride),
      weights_(weights.reshape(1, weights.size[0]).clone()),
      bias_(std::size_t(channels_), 0.f) {
  for (int c = 0; c < channels_ && !bias.empty(); ++c) bias_[std::size_t(c)] = bias.ptr<float>()[c];
}

bool BandedDepthwise::takes(const cv::Mat& weights, const cv::Mat& bias, int channels, int kernel,
                            int stride, int pad_top, int pad_left, int pad_bottom, int pad_right,
                            int dilation_y, int dilation_x) {
  if (!depthwise_avx2_supported() || weights.dims != 4 || weights.type() != CV_32F ||
      !weights.isContinuous())
    return false;
  const int pad = kernel / 2;
  return weights.size[0] == channels && weights.size[1] == 1 && weights.size[2] == kernel &&
         weights.size[3] == kernel && kernel % 2 == 1 && (stride == 1 || stride == 2) &&
         pad_top == pad && pad_left == pad && pad_bottom == pad && pad_right == pad &&
         dilation_y == 1 && dilation_x == 1 &&
         (bias.empty() || (bias.type() == CV_32F && int(bias.total()) == channels));
}

void BandedDepthwise::run(const Rows& produce, int h, int w, float* dst,
                          const cv::dnn::ActivationLayer* activation) {
  const int pad = kernel_ / 2, ho = output_side(h), wo = output_side(w);
  const std::size_t out_plane = std::size_t(ho) * wo;
  // Output rows [y0, y0 + rows) read input rows y0 s - pad .. (y0 + rows - 1) s - pad + k - 1:
  // rows s + k - s of them; as many output rows as the buffer holds, at least one.
  const std::size_t row_bytes = std::size_t(channels_) * w * sizeof(float);
  const int fit = int(kBandBytes / row_bytes);
  const int rows = std::max(1, (fit - (kernel_ - stride_)) / stride_);
  const int most_input_rows = std::min(h, rows * stride_ + kernel_ - stride_);
  const std::size_t band_plane = std::size_t(most_input_rows) * w;
  band_.resize(std::size_t(channels_) * band_plane);
  int held_first = 0, held_last = 0;  // the input rows the buffer holds, from its first row
  for (int y0 = 0; y0 < ho; y0 += rows) {
    const int y1 = std::min(ho, y0 + rows);
    const int first = std::max(0, y0 * stride_ - pad);
    const int last = std::min(h, (y1 - 1) * stride_ - pad + kernel_);  // one past
    // The rows the last band also read (k - s of them) moved to the top, not computed again.
    const int kept = std::max(0, held_last - first);
    if (kept > 0 && first > held_first)
      for (int c = 0; c < channels_; ++c) {
        float* plane = band_.data() + c * band_plane;
        std::copy_n(plane + std::size_t(first - held_first) * w, std::size_t(kept) * w, plane);
      }
    if (last > first + kept)
      produce(first + kept, last, band_.data() + std::size_t(kept) * w, band_plane);
    held_first = first;
    held_last = last;
    // Output row y reads band row (y - y0) s - top + ky: rows above the image are zero padding.
    const int top = first - (y0 * stride_ - pad);
    cv::parallel_for_(cv::Range(0, channels_), [&](const cv::Range& planes) {
      for (int c = planes.start; c < planes.end; ++c) {
        float* out = dst + c * out_plane + std::size_t(y0) * wo;
        depthwise_plane_avx2(band_.data() + c * band_plane, last - first, w, weights_.ptr<float>(c),
                             kernel_, kernel_, 1, 1, top, pad, stride_, stride_,
                             bias_[std::size_t(c)], out, y1 - y0, wo);
        if (activation) activation->forwardSlice(out, out, (y1 - y0) * wo, out_plane, c, c + 1);
      }
    });
  }
}

}  // namespace keyfleet::vision
