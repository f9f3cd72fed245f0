#include "strided_convolution.hpp"

#include <algorithm>
#include <cstring>

#include "depthwise_avx2.hpp"

namespace keyfleet::vision {

StridedConvolution::StridedConvolution(const cv::Mat& weights, const cv::Mat& bias, int pad)
    : cin_(weights.size[1]),
      k_(weights.size[2]),
      pad_(pad),
      // [outputs][inputs][k][k] is already [outputs][inputs k k][1][1].
      product_(weights.reshape(1, {weights.size[0], cin_ * k_ * k_, 1, 1}), bias, false) {
  CV_Assert(weights.dims == 4 && weights.type() == CV_32F && weights.isContinuous() &&
            weights.size[2] == weights.size[3] && pad >= 0 && pad < k_);
}

void StridedConvolution::run(const float* src, int h, int w, float* dst,
                             const cv::dnn::ActivationLayer* activation) {
  const int ho = output_side(h), wo = output_side(w);
  CV_Assert(ho > 0 && wo > 0);
  run_rows(src, h, w, 0, ho, dst, std::size_t(ho) * wo, activation);
}

void StridedConvolution::run_rows(const float* src, int h, int w, int first, int last, float* dst,
                                  std::size_t dst_plane,
                                  const cv::dnn::ActivationLayer* activation) {
  const int ho = output_side(h), wo = output_side(w);
  CV_Assert(ho > 0 && wo > 0 && first >= 0 && first < last && last <= ho);
  const int taps = cin_ * k_ * k_;
  // Bands of output rows whose planes stay in L2 (at 640x480 the whole image's would be 8 MB).
  const int band = std::clamp(kBandFloats / (taps * wo), 1, last - first);
  columns_.resize(std::size_t(taps) * band * wo);
  products_.resize(std::size_t(output_channels()) * band * wo);
  // A bordered row: pad zeros, the input row, zeros up to the last tap's column.
  const int width = std::max(2 * (wo - 1) + k_, w + pad_) + 1;
  row_.assign(std::size_t(width), 0.f);
  even_.resize(std::size_t(width + 1) / 2);
  odd_.resize(std::size_t(width + 1) / 2);
  for (int y0 = first; y0 < last; y0 += band) {
    const int y1 = std::min(last, y0 + band);
    const std::size_t pixels = std::size_t(y1 - y0) * wo;
    for (int c = 0; c < cin_; ++c) {
      const float* plane = src + std::size_t(c) * h * w;
      // Bordered row r (input row r - pad) feeds output rows y with r = 2 y + ky.
      for (int r = 2 * y0; r < 2 * (y1 - 1) + k_; ++r) {
        const int iy = r - pad_;
        if (iy >= 0 && iy < h) {
          std::memcpy(row_.data() + pad_, plane + std::size_t(iy) * w, sizeof(float) * w);
          split_even_odd_columns(row_.data(), width, even_.data(), odd_.data());
        } else {
          std::fill(even_.begin(), even_.end(), 0.f);
          std::fill(odd_.begin(), odd_.end(), 0.f);
        }
        for (int ky = r % 2; ky < k_; ky += 2) {
          const int y = (r - ky) / 2;
          if (y < y0 || y >= y1) continue;
          for (int kx = 0; kx < k_; ++kx) {
            // Output column x reads bordered column 2 x + kx: that phase's column x + kx / 2.
            const float* from = (kx % 2 ? odd_.data() : even_.data()) + kx / 2;
            float* to = columns_.data() + (std::size_t(c * k_ + ky) * k_ + kx) * pixels +
                        std::size_t(y - y0) * wo;
            std::memcpy(to, from, sizeof(float) * wo);
          }
        }
      }
    }
    product_.run(columns_.data(), int(pixels), products_.data(), activation);
    for (int o = 0; o < output_channels(); ++o)  // whole rows: one run of each output plane
      std::memcpy(dst + o * dst_plane + std::size_t(y0 - first) * wo, products_.data() + o * pixels,
                  sizeof(float) * pixels);
  }
}

}  // namespace keyfleet::vision
