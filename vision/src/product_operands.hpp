#pragma once
// What the product stand-ins (pointwise, sub-pixel and 3x3 convolutions) share: their weights
// and input laid out for the matrix-product kernels (float or bfloat16), their bias padded to
// whole row blocks, and the step that multiplies one block of them. Internal to keyfleet_vision.
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <cstdint>
#include <functional>
#include <vector>

#include "avx2_product.hpp"

namespace keyfleet::vision {

inline int round_up(int value, int multiple) {
  return (value + multiple - 1) / multiple * multiple;
}

// The summed dimension's length: the input channels, or their pairs in bfloat16.
inline int summed_length(int inputs, bool bfloat16) { return bfloat16 ? (inputs + 1) / 2 : inputs; }

// `rows` rows of `width` floats into out: row r is src's row r - top (h rows of w floats) behind
// `left` zeros and followed by zeros; rows outside src are zeros. Each float written once.
void copy_with_zero_border(const float* src, int h, int w, int top, int left, int rows, int width,
                           float* out);

// A buffer of rows of `width` floats that holds a plane's rows behind a zero border, as
// copy_with_zero_border lays them out, and keeps that border from one fill to the next: where
// the last fill had the same left, w and width and at least as many rows, the plane's rows are
// copied alone (rows outside it zeroed whole), else every float is written. For kernels that
// copy plane after plane (a layer's channels, a band's) of one geometry: the per-row fills cost
// more than the copy on narrow planes. One per thread.
class ZeroBorderedRows {
 public:
  // The filled buffer: `rows` rows, row r being src's row r - top.
  const float* fill(const float* src, int h, int w, int top, int left, int rows, int width);

 private:
  std::vector<float> floats_;
  int rows_ = 0, width_ = 0, w_ = 0, left_ = 0;  // the border written last
};

// Columns [n0, n1) of a 1x1 product's `outputs` planes into dst (planes of `pixels` floats), the
// activation (may be null) applied on the way: from `products` (planes `columns` apart), or in
// place where products is null (the product was written straight into dst).
void finish_columns(const float* products, std::size_t columns, int outputs, int n0, int n1,
                    float* dst, int pixels, const cv::dnn::ActivationLayer* activation);

// One float per output, zero where `bias` is empty, padded with zeros to a multiple of 24 (whole
// row blocks of every block shape).
std::vector<float> padded_bias(const cv::Mat& bias, int outputs);

// [row block][tap][summed index][block rows]: floats, or bfloat16 pairs of input channels.
struct PackedWeights {
  std::vector<float> floats;
  std::vector<std::uint32_t> pairs;

  // weight(output, input, tap) for output < outputs, input < inputs, tap < taps.
  void pack(ProductBlock block, int taps, int inputs, int outputs, bool bfloat16,
            const std::function<float(int, int, int)>& weight);
};

// What the product stand-ins hold alike: the weights (4-D float, kernel x kernel taps) and their
// channel counts, the bias padded (padded_bias), and whether the products run in bfloat16 (asked
// for, and bf16_product_pays for the outputs: the CPU has AVX512-BF16, 8 or more outputs).
class ProductKernel {
 public:
  int input_channels() const { return cin_; }
  int output_channels() const { return cout_; }
  bool bfloat16() const { return bfloat16_; }

 protected:
  // weights: outputs x inputs x kernel x kernel, or inputs x outputs x kernel x kernel where
  // `transposed` (ONNX ConvTranspose's layout); bias: empty or one float per output.
  ProductKernel(const cv::Mat& weights, const cv::Mat& bias, bool bfloat16, int kernel,
                bool transposed);
  // The length of the summed dimension: input channels, or their pairs.
  int summed() const { return summed_length(cin_, bfloat16_); }

  int cin_, cout_;
  bool bfloat16_;
  cv::Mat weights_;
  std::vector<float> bias_;
};

// The summed dimension's chunk: chunks of it whose columns of a block (all taps) stay within
// about 16 KB (L1), as even as they come.
int summed_chunk(int total, int taps, int columns);

// A layer's input as the kernels read it: a plane of plane() elements per summed index (input
// channel, or pair of channels in bfloat16), zero where the source does not reach.
class ProductInput {
 public:
  // src's channels (planes of rows x width, contiguous) at `offset` of their planes, rows
  // `row_stride` apart.
  void fill(const float* src, int channels, int rows, int width, bool bfloat16, std::size_t plane,
            int row_stride, int offset = 0);
  // src itself, float planes `plane` apart.
  void use(const float* src, std::size_t plane);
  std::size_t plane() const { return plane_; }

  // out (block.rows x block.columns, rows out_stride apart) = (bias or out) + the weights'
  // block at `a` times this input from summed index k0 and column n0, over depth summed indices
  // and `taps` taps at their shifts (avx2_product.hpp, bf16_product.hpp).
  // `stream`: in float, written past the caches (product_block's); bfloat16 ignores it.
  void multiply(ProductBlock block, int taps, const PackedWeights& weights, std::size_t a,
                std::size_t tap_stride, int k0, int n0, const int* shifts, int depth,
                const float* bias, float* out, std::size_t out_stride, bool stream = false) const;

 private:
  const float* floats_ = nullptr;
  const std::uint32_t* pairs_ = nullptr;  // set in bfloat16 (then floats_ is null)
  std::size_t plane_ = 0;
  std::vector<float> float_buffer_;
  std::vector<std::uint32_t> pair_buffer_;
};

}  // namespace keyfleet::vision
