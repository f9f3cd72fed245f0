#include "product_operands.hpp"

#include <algorithm>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "bf16_product.hpp"

namespace keyfleet::vision {

void copy_with_zero_border(const float* src, int h, int w, int top, int left, int rows, int width,
                           float* out) {
  for (int r = 0; r < rows; ++r) {
    float* row = out + std::size_t(r) * width;
    const int y = r - top;
    if (y < 0 || y >= h) {
      std::fill(row, row + width, 0.f);
      continue;
    }
    std::fill(row, row + left, 0.f);
    std::copy_n(src + std::size_t(y) * w, w, row + left);
    std::fill(row + left + w, row + width, 0.f);
  }
}

namespace {

// n floats from src to dst (in AVX2 where built for x86-64: a library call a row costs more than
// a narrow row's copy).
#if defined(__GNUC__) && defined(__x86_64__)
__attribute__((target("avx2"))) void copy_floats(const float* src, int n, float* dst) {
  int x = 0;
  for (; x + 8 <= n; x += 8) _mm256_storeu_ps(dst + x, _mm256_loadu_ps(src + x));
  for (; x < n; ++x) dst[x] = src[x];
}
#else
void copy_floats(const float* src, int n, float* dst) { std::copy_n(src, n, dst); }
#endif

}  // namespace

const float* ZeroBorderedRows::fill(const float* src, int h, int w, int top, int left, int rows,
                                    int width) {
  if (rows_ < rows || width_ != width || w_ != w || left_ != left) {
    floats_.resize(std::size_t(rows) * width);
    copy_with_zero_border(src, h, w, top, left, rows, width, floats_.data());
    rows_ = rows, width_ = width, w_ = w, left_ = left;
    return floats_.data();
  }
  for (int r = 0; r < rows; ++r) {
    float* row = floats_.data() + std::size_t(r) * width;
    const int y = r - top;
    if (y < 0 || y >= h)
      std::fill(row, row + width, 0.f);
    else
      copy_floats(src + std::size_t(y) * w, w, row + left);
  }
  return floats_.data();
}

void finish_columns(const float* products, std::size_t columns, int outputs, int n0, int n1,
                    float* dst, int pixels, const cv::dnn::ActivationLayer* activation) {
  if (n1 <= n0) return;
  if (!products) {
    if (activation) activation->forwardSlice(dst + n0, dst + n0, n1 - n0, pixels, 0, outputs);
    return;
  }
  for (int c = 0; c < outputs; ++c) {
    const float* from = products + std::size_t(c) * columns + n0;
    float* to = dst + std::size_t(c) * pixels + n0;
    if (activation)
      activation->forwardSlice(from, to, n1 - n0, pixels, c, c + 1);
    else
      std::copy(from, from + (n1 - n0), to);
  }
}

std::vector<float> padded_bias(const cv::Mat& bias, int outputs) {
  CV_Assert(bias.empty() || (bias.type() == CV_32F && int(bias.total()) == outputs));
  std::vector<float> padded(std::size_t((outputs + 23) / 24 * 24), 0.f);
  for (int c = 0; c < outputs && !bias.empty(); ++c) padded[c] = bias.ptr<float>()[c];
  return padded;
}

ProductKernel::ProductKernel(const cv::Mat& weights, const cv::Mat& bias, bool bfloat16, int kernel,
                             bool transposed)
    : cin_(weights.size[transposed ? 0 : 1]),
      cout_(weights.size[transposed ? 1 : 0]),
      bfloat16_(bfloat16 && bf16_product_pays(cout_)),
      weights_(weights),
      bias_(padded_bias(bias, cout_)) {
  CV_Assert(weights.dims == 4 && weights.type() == CV_32F && weights.isContinuous() &&
            weights.size[2] == kernel && weights.size[3] == kernel);
}

void PackedWeights::pack(ProductBlock block, int taps, int inputs, int outputs, bool bfloat16,
                         const std::function<float(int, int, int)>& weight) {
  const int row_blocks = (outputs + block.rows - 1) / block.rows;
  const int depth = summed_length(inputs, bfloat16);
  const std::size_t size = std::size_t(row_blocks) * taps * depth * block.rows;
  floats.assign(bfloat16 ? 0 : size, 0.f);
  pairs.assign(bfloat16 ? size : 0, 0u);
  for (int co = 0; co < outputs; ++co)
    for (int t = 0; t < taps; ++t)
      for (int k = 0; k < depth; ++k) {
        const std::size_t i =
            ((std::size_t(co / block.rows) * taps + t) * depth + k) * block.rows + co % block.rows;
        if (bfloat16)
          pairs[i] =
              bf16_pair(weight(co, 2 * k, t), 2 * k + 1 < inputs ? weight(co, 2 * k + 1, t) : 0.f);
        else
          floats[i] = weight(co, k, t);
      }
}

int summed_chunk(int total, int taps, int columns) {
  const int most = std::max(8, 4096 / (taps * columns));
  const int chunks = (total + most - 1) / most;
  return (total + chunks - 1) / chunks;
}

void ProductInput::fill(const float* src, int channels, int rows, int width, bool bfloat16,
                        std::size_t plane, int row_stride, int offset) {
  plane_ = plane;
  if (bfloat16) {
    pair_buffer_.assign(std::size_t(summed_length(channels, true)) * plane, 0u);
    pack_bf16_pairs(src, channels, rows, width, pair_buffer_.data() + offset, plane, row_stride);
    pairs_ = pair_buffer_.data(), floats_ = nullptr;
    return;
  }
  float_buffer_.assign(std::size_t(channels) * plane, 0.f);
  for (int c = 0; c < channels; ++c)
    for (int y = 0; y < rows; ++y)
      std::copy_n(src + (std::size_t(c) * rows + y) * width, width,
                  float_buffer_.data() + c * plane + offset + std::size_t(y) * row_stride);
  floats_ = float_buffer_.data(), pairs_ = nullptr;
}

void ProductInput::use(const float* src, std::size_t plane) {
  floats_ = src, pairs_ = nullptr, plane_ = plane;
}

void ProductInput::multiply(ProductBlock block, int taps, const PackedWeights& weights,
                            std::size_t a, std::size_t tap_stride, int k0, int n0,
                            const int* shifts, int depth, const float* bias, float* out,
                            std::size_t out_stride, bool stream) const {
  const std::size_t at = std::size_t(k0) * plane_ + n0;
  if (pairs_)
    product_block_bf16(block, taps, weights.pairs.data() + a, tap_stride, pairs_ + at, shifts,
                       depth, plane_, bias, out, out_stride);
  else
    product_block(block, taps, weights.floats.data() + a, tap_stride, floats_ + at, shifts, depth,
                  plane_, bias, out, out_stride, stream);
}

}  // namespace keyfleet::vision
