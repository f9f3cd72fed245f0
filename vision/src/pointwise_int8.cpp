#include "pointwise_int8.hpp"

#include <algorithm>
#include <cmath>

#include "int8_product.hpp"
#include "product_operands.hpp"

namespace keyfleet::vision {

Int8PointwiseConvolution::Int8PointwiseConvolution(const cv::Mat& weights, const cv::Mat& bias,
                                                   bool)
    : cin_(weights.size[1]),
      cout_(weights.size[0]),
      quads_((weights.size[1] + 3) / 4),
      bias_(padded_bias(bias, weights.size[0])) {
  CV_Assert(weights.dims == 4 && weights.type() == CV_32F && weights.isContinuous() &&
            weights.size[2] == 1 && weights.size[3] == 1);
  weight_scale_.resize(cout_);
  weight_sum_.resize(cout_);
  quantized_.resize(std::size_t(cout_) * cin_);
  for (int co = 0; co < cout_; ++co) {
    const float* w = weights.ptr<float>() + std::size_t(co) * cin_;
    std::int8_t* q = quantized_.data() + std::size_t(co) * cin_;
    float largest = 0.f;
    for (int ci = 0; ci < cin_; ++ci) largest = std::max(largest, std::abs(w[ci]));
    weight_scale_[co] = largest > 0.f ? largest / kInt8WeightLimit : 1.f;
    long sum = 0;
    for (int ci = 0; ci < cin_; ++ci)
      sum += q[ci] = std::int8_t(std::lrint(w[ci] / weight_scale_[co]));
    weight_sum_[co] = float(sum);
  }
}

void Int8PointwiseConvolution::pack(ProductBlock block) {
  block_ = block;
  row_blocks_ = (cout_ + block.rows - 1) / block.rows;
  packed_.assign(std::size_t(row_blocks_) * quads_ * block.rows, 0u);
  for (int co = 0; co < cout_; ++co)
    for (int ci = 0; ci < cin_; ++ci) {
      const std::size_t i =
          (std::size_t(co / block.rows) * quads_ + ci / 4) * block.rows + co % block.rows;
      packed_[i] |= std::uint32_t(std::uint8_t(quantized_[std::size_t(co) * cin_ + ci]))
                    << (8 * (ci % 4));
    }
}

void Int8PointwiseConvolution::run(const float* src, int pixels, float* dst,
                                   const cv::dnn::ActivationLayer* activation) {
  // Rows that divide the outputs where a shape's do (the products then go straight to dst, the
  // columns' remainder through a small buffer), else the least padding.
  const ProductBlock block = cout_ % 4 == 0   ? ProductBlock{4, 16}
                             : cout_ % 2 == 0 ? ProductBlock{2, 32}
                                              : int8_product_block(cout_, pixels);
  if (block.rows != block_.rows) pack(block);
  const int width = block_.columns;
  const int columns = (pixels + width - 1) / width * width;

  // The input over its own range, zero included (so that zero, the padding, is exact).
  float lowest = 0.f, highest = 0.f;
  float_range(src, std::size_t(cin_) * pixels, &lowest, &highest);
  lowest = std::min(lowest, 0.f), highest = std::max(highest, 0.f);
  const float step = highest > lowest ? (highest - lowest) / kInt8InputLevels : 1.f;
  const int zero = int(std::clamp(std::lrint(-lowest / step), 0L, long(kInt8InputLevels)));
  input_.resize(std::size_t(quads_) * columns);
  quantize_quads(src, cin_, pixels, 1.f / step, zero, input_.data(), columns);
  // out = weight scale x step x (sum - zero x weight sum) + bias.
  scale_.assign(bias_.size(), 0.f);
  offset_.assign(bias_.size(), 0.f);
  for (int co = 0; co < cout_; ++co) {
    scale_[co] = weight_scale_[co] * step;
    offset_[co] = bias_[co] - scale_[co] * float(zero) * weight_sum_[co];
  }

  // Whole row blocks: the products of whole column blocks straight into dst, those of the
  // columns' remainder into a buffer of one block's columns, copied into dst after. Else all of
  // them into a buffer first.
  const bool in_place = cout_ % block_.rows == 0;
  const int whole = pixels / width, tail = pixels - whole * width;
  if (!in_place)
    products_.resize(std::size_t(row_blocks_) * block_.rows * columns);
  else if (tail)
    products_.resize(std::size_t(cout_) * width);
  // Quads in chunks whose block columns stay within about 16 KB (L1); stripes of a few blocks,
  // finished (activation included) before the next.
  const int depth = summed_chunk(quads_, 1, width);
  constexpr int kStripe = 4;
  const int blocks = columns / width;
  const int stripes = (blocks + kStripe - 1) / kStripe;
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
    for (int stripe = range.start; stripe < range.end; ++stripe) {
      const int first = stripe * kStripe, last = std::min(blocks, first + kStripe);
      for (int k0 = 0; k0 < quads_; k0 += depth) {
        const int k = std::min(depth, quads_ - k0);
        for (int blk = first; blk < last; ++blk) {
          // Where this block's products go, and how far apart their rows are.
          float* base = products_.data() + blk * width;
          std::size_t stride = columns;
          if (in_place && blk < whole)
            base = dst + blk * width, stride = pixels;
          else if (in_place)
            base = products_.data(), stride = width;
          for (int rb = 0; rb < row_blocks_; ++rb) {
            const std::uint32_t* a = packed_.data() + (std::size_t(rb) * quads_ + k0) * block_.rows;
            const std::uint32_t* b = input_.data() + std::size_t(k0) * columns + blk * width;
            const int r0 = rb * block_.rows;
            product_block_int8(block_, a, b, k, columns, scale_.data() + r0,
                               k0 == 0 ? offset_.data() + r0 : nullptr,
                               base + std::size_t(r0) * stride, stride);
          }
        }
      }
      if (in_place && tail && last == blocks)
        for (int c = 0; c < cout_; ++c)
          std::copy_n(products_.data() + std::size_t(c) * width, tail,
                      dst + std::size_t(c) * pixels + whole * width);
      finish_columns(in_place ? nullptr : products_.data(), columns, cout_, first * width,
                     std::min(pixels, last * width), dst, pixels, activation);
    }
  });
}

}  // namespace keyfleet::vision
