#include "pointwise_convolution.hpp"

#include <algorithm>

namespace keyfleet::vision {

void PointwiseConvolution::pack(ProductBlock block) {
  block_ = block;
  row_blocks_ = (cout_ + block_.rows - 1) / block_.rows;
  const float* w = weights_.ptr<float>();  // [cout][cin]
  packed_.pack(block, 1, cin_, cout_, bfloat16_,
               [&](int co, int ci, int) { return w[std::size_t(co) * cin_ + ci]; });
}

void PointwiseConvolution::run(const float* src, int pixels, float* dst,
                               const cv::dnn::ActivationLayer* activation) {
  const ProductBlock block =
      bfloat16_ ? bf16_product_block(cout_, pixels) : float_product_block(cout_, pixels);
  if (block.rows != block_.rows) pack(block);
  const int width = block_.columns;
  const int columns = (pixels + width - 1) / width * width;
  // The input in place when its planes are whole blocks, else copied with zero columns after;
  // in bfloat16, converted to pairs with zero columns after.
  if (bfloat16_ || columns != pixels)
    input_.fill(src, cin_, 1, pixels, bfloat16_, columns, pixels);
  else
    input_.use(src, columns);
  // The products straight into dst when they fill it exactly, else into a buffer first.
  const bool direct = columns == pixels && cout_ % block_.rows == 0;
  float* out = dst;
  if (!direct) {
    products_.resize(std::size_t(row_blocks_) * block_.rows * columns);
    out = products_.data();
  }
  // Input channels in chunks whose block columns stay within about 16 KB (L1); stripes of a
  // few blocks, finished (activation included) before the next.
  const int total = summed(), depth = summed_chunk(total, 1, width);
  constexpr int kStripe = 4;
  const int stripes = (columns / width + kStripe - 1) / kStripe;
  const int zero_shift = 0;
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
    for (int stripe = range.start; stripe < range.end; ++stripe) {
      const int first = stripe * kStripe, last = std::min(columns / width, first + kStripe);
      for (int k0 = 0; k0 < total; k0 += depth) {
        const int k = std::min(depth, total - k0);
        for (int blk = first; blk < last; ++blk)
          for (int rb = 0; rb < row_blocks_; ++rb) {
            const std::size_t a = (std::size_t(rb) * total + k0) * block_.rows;
            const float* bias = k0 == 0 ? bias_.data() + rb * block_.rows : nullptr;
            float* o = out + std::size_t(rb) * block_.rows * columns + blk * width;
            input_.multiply(block_, 1, packed_, a, 0, k0, blk * width, &zero_shift, k, bias, o,
                            columns);
          }
      }
      finish_columns(direct ? nullptr : out, columns, cout_, first * width,
                     std::min(pixels, last * width), dst, pixels, activation);
    }
  });
}

}  // namespace keyfleet::vision
