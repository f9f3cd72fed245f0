#include "convolution_3x3.hpp"

#include <algorithm>

namespace keyfleet::vision {

Convolution3x3::Convolution3x3(const cv::Mat& weights, const cv::Mat& bias, bool bfloat16)
    : ProductKernel(weights, bias, bfloat16, 3, false) {
  if (!bfloat16_ && cin_ >= 8 && cout_ >= 8)
    winograd_ = std::make_unique<Winograd3x3>(weights, bias);
}

void Convolution3x3::pack(ProductBlock block) {
  block_ = block;
  row_blocks_ = (cout_ + block.rows - 1) / block.rows;
  const float* w = weights_.ptr<float>();  // [cout][cin][3][3]
  packed_.pack(block, 9, cin_, cout_, bfloat16_,
               [&](int co, int ci, int tap) { return w[(std::size_t(co) * cin_ + ci) * 9 + tap]; });
}

void Convolution3x3::multiply(int block_begin, int block_end) {
  const int total = summed(), depth = summed_chunk(total, 9, block_.columns);
  const std::size_t tap_stride = std::size_t(total) * block_.rows;
  for (int k0 = 0; k0 < total; k0 += depth) {
    const int k = std::min(depth, total - k0);
    for (int block = block_begin; block < block_end; ++block) {
      const int n0 = block * block_.columns;
      for (int rb = 0; rb < row_blocks_; ++rb) {
        const std::size_t a = (std::size_t(rb) * 9 * total + k0) * block_.rows;
        const float* bias = k0 == 0 ? bias_.data() + rb * block_.rows : nullptr;
        float* o = products_.data() + std::size_t(rb) * block_.rows * columns_ + n0;
        input_.multiply(block_, 9, packed_, a, tap_stride, k0, n0, shifts_, k, bias, o, columns_);
      }
    }
  }
}

void Convolution3x3::run(const float* src, int h, int w, float* dst,
                         const cv::dnn::ActivationLayer* activation) {
  if (winograd_) {
    winograd_->run(src, h, w, dst, activation);
    return;
  }
  // Each plane gets a zero border (a column either side, a row above and below); products are
  // computed on the bordered width from the top-left of the border, so output (y, x) is column
  // y * (w + 2) + x and the two columns past w of each row are dropped.
  const int width = w + 2;
  const ProductBlock block =
      bfloat16_ ? bf16_product_block(cout_, h * width) : float_product_block(cout_, h * width);
  if (block.rows != block_.rows) pack(block);
  columns_ = round_up(h * width, block_.columns);
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx) shifts_[ky * 3 + kx] = ky * width + kx;
  input_.fill(src, cin_, h, w, bfloat16_, round_up(columns_ + 2 * width + 2, 16), width, width + 1);
  products_.resize(std::size_t(row_blocks_) * block_.rows * columns_);
  cv::parallel_for_(cv::Range(0, columns_ / block_.columns),
                    [&](const cv::Range& blocks) { multiply(blocks.start, blocks.end); });

  const std::size_t out_plane = std::size_t(h) * w;
  cv::parallel_for_(cv::Range(0, cout_), [&](const cv::Range& channels) {
    for (int c = channels.start; c < channels.end; ++c) {
      float* plane = dst + c * out_plane;
      for (int y = 0; y < h; ++y)
        std::copy_n(products_.data() + std::size_t(c) * columns_ + std::size_t(y) * width, w,
                    plane + std::size_t(y) * w);
      if (activation) activation->forwardSlice(plane, plane, int(out_plane), out_plane, c, c + 1);
    }
  });
}

}  // namespace keyfleet::vision
