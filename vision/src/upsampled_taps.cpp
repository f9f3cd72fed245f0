#include "upsampled_taps.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>

#include "product_operands.hpp"
#include "upsampling_hand_over.hpp"

namespace keyfleet::vision {
namespace {

constexpr int kTaps = 9;

enum class RowClass { top, middle, bottom };

}  // namespace

UpsampledTaps::UpsampledTaps(const cv::Mat& weights, int first, int channels)
    : outputs_(weights.size[0]), first_(first), channels_(channels) {
  CV_Assert(weights.dims == 4 && weights.type() == CV_32F && weights.isContinuous() &&
            weights.size[2] == 3 && weights.size[3] == 3 && first >= 0 && channels > 0 &&
            first + channels <= weights.size[1]);
  const int inputs = weights.size[1];
  const float* all = weights.ptr<float>();  // [outputs][inputs][3][3]
  weights_.resize(std::size_t(kTaps) * outputs_ * channels_);
  for (int o = 0; o < outputs_; ++o)
    for (int c = 0; c < channels_; ++c)
      for (int t = 0; t < kTaps; ++t)
        weights_[(std::size_t(t) * outputs_ + o) * channels_ + c] =
            all[(std::size_t(o) * inputs + first + c) * kTaps + t];
}

void UpsampledTaps::multiply(const float* source, int h, int w) {
  const int rows = kTaps * outputs_, columns = h * w;
  const ProductBlock block = float_product_block(rows, columns);
  if (block.rows != block_.rows || block.columns != block_.columns) {
    block_ = block;  // the weights packed for blocks of that many rows
    const int row_blocks = (rows + block.rows - 1) / block.rows;
    packed_.assign(std::size_t(row_blocks) * channels_ * block.rows, 0.f);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < channels_; ++c)
        packed_[(std::size_t(r / block.rows) * channels_ + c) * block.rows + r % block.rows] =
            weights_[std::size_t(r) * channels_ + c];
    zeros_.assign(std::size_t(block.rows), 0.f);
  }
  h_ = h;
  w_ = w;
  stride_ = round_up(columns, block_.columns);
  source_.assign(std::size_t(channels_) * stride_, 0.f);
  for (int c = 0; c < channels_; ++c)
    std::copy_n(source + std::size_t(c) * columns, columns,
                source_.data() + std::size_t(c) * stride_);
  const int row_blocks = (rows + block_.rows - 1) / block_.rows;
  products_.resize(std::size_t(row_blocks) * block_.rows * stride_);
  const int column_blocks = stride_ / block_.columns;
  const int shifts[1] = {0};
  cv::parallel_for_(cv::Range(0, row_blocks * column_blocks), [&](const cv::Range& range) {
    for (int job = range.start; job < range.end; ++job) {
      const int rb = job / column_blocks, n0 = (job % column_blocks) * block_.columns;
      product_block(block_, 1, packed_.data() + std::size_t(rb) * channels_ * block_.rows, 0,
                    source_.data() + n0, shifts, channels_, std::size_t(stride_), zeros_.data(),
                    products_.data() + std::size_t(rb) * block_.rows * stride_ + n0,
                    std::size_t(stride_));
    }
  });
}

void UpsampledTaps::add_to(int output, int ky, int kx, float* plane) const {
  const int h = h_, w = w_, width = w * kx;
  // The products of tap (dy, dx) for this output: a plane of h x w at stride w.
  auto tap = [&](int dy, int dx) {
    return products_.data() + std::size_t((dy + 1) * 3 + dx + 1) * outputs_ * stride_ +
           std::size_t(output) * stride_;
  };
  std::vector<float> sums(3 * std::size_t(w)), left(w), middle(w), right(w), row(width);
  for (int sy = 0; sy < h; ++sy) {
    for (const RowClass cls : {RowClass::top, RowClass::middle, RowClass::bottom}) {
      if (cls == RowClass::middle && ky < 3) continue;
      // Each column tap's sum over the row taps that read a row of the source.
      std::fill(sums.begin(), sums.end(), 0.f);
      for (int dy = -1; dy <= 1; ++dy) {
        int from = sy;
        if (dy == -1 && cls == RowClass::top) from = sy - 1;
        if (dy == 1 && cls == RowClass::bottom) from = sy + 1;
        if (from < 0 || from >= h) continue;  // the convolution's zero border
        for (int dx = -1; dx <= 1; ++dx)
          add_floats(sums.data() + std::size_t(dx + 1) * w, tap(dy, dx) + std::size_t(from) * w,
                     sums.data() + std::size_t(dx + 1) * w, w);
      }
      const float* before = sums.data();  // column tap -1
      const float* same = sums.data() + w;
      const float* after = sums.data() + 2 * std::size_t(w);
      for (int sx = 0; sx < w; ++sx) {
        middle[sx] = before[sx] + same[sx] + after[sx];
        left[sx] = (sx > 0 ? before[sx - 1] : 0.f) + same[sx] + after[sx];
        right[sx] = before[sx] + same[sx] + (sx + 1 < w ? after[sx + 1] : 0.f);
      }
      repeat_columns(middle.data(), w, kx, row.data());
      for (int sx = 0; sx < w; ++sx) {
        row[std::size_t(sx) * kx] = left[sx];
        row[std::size_t(sx) * kx + kx - 1] = right[sx];
      }
      int y0 = sy * ky, y1 = y0 + 1;  // top
      if (cls == RowClass::middle) y0 += 1, y1 = sy * ky + ky - 1;
      if (cls == RowClass::bottom) y0 = sy * ky + ky - 1, y1 = y0 + 1;
      for (int y = y0; y < y1; ++y) {
        float* out = plane + std::size_t(y) * width;
        add_floats(out, row.data(), out, width);
      }
    }
  }
}

}  // namespace keyfleet::vision
