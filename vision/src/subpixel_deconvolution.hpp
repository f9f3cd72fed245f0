#pragma once
// A transposed convolution with stride 2 whose output is twice the input in each direction,
// computed as its four sub-pixel convolutions: output pixel (2i + a, 2j + b) only ever meets the
// kernel taps of its phase (a, b). Two geometries:
// - 3x3, padding 1, output padding 1 (MiniNet's upsampling): 1, 2, 2 and 4 taps of the nine,
//   applied to input pixels (i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1); each phase is one
//   matrix product over the input read in place;
// - 2x2, no padding (PP-OCR's DB head): tap (a, b) alone, applied to input pixel (i, j), so the
//   four phases are one 1x1 convolution with four times the outputs (pointwise_convolution.hpp).
// No scatter of partial sums (OpenCV's col2im) and no multiplication by zero. Internal to
// keyfleet_vision (dnn_layers.cpp wraps it).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "avx2_product.hpp"
#include "bf16_product.hpp"
#include "pointwise_convolution.hpp"
#include "product_operands.hpp"

namespace keyfleet::vision {

class SubpixelDeconvolution : public ProductKernel {
 public:
  // Whether this CPU runs the kernel (x86-64 with AVX2 and FMA); elsewhere OpenCV's layer stays.
  static bool supported();

  // weights: input channels x output channels x k x k, k = 3 or 2 (ONNX ConvTranspose's layout,
  // the geometries above), float;
  // bias: empty or one float per output channel. bfloat16: multiply in bfloat16 pairs (sums in
  // float) where bf16_product_pays (the CPU has AVX512-BF16, 8 or more output channels); the
  // 2x2 geometry always multiplies in float.
  SubpixelDeconvolution(const cv::Mat& weights, const cv::Mat& bias, bool bfloat16);

  // One image: src is input_channels planes of h x w, dst output_channels planes of 2h x 2w,
  // each set contiguous; `activation` (may be null) is applied to each output plane once written.
  // Runs on cv::parallel_for_'s threads. Not reentrant (work buffers).
  void run(const float* src, int h, int w, float* dst, const cv::dnn::ActivationLayer* activation);

  // 2x2 with more outputs than kNarrowOutputs (PP-OCR's 24 -> 24), and with at most that many
  // (its 24 -> 1): a pair run a band of rows at a time, the first's output rows kept in cache
  // for the second (dnn_layers.cpp fuses them).
  bool wide_2x2() const { return kernel_ == 2 && cout_ > kNarrowOutputs; }
  bool narrow_2x2() const { return kernel_ == 2 && cout_ <= kNarrowOutputs; }
  // wide_2x2(): output rows [2 y0, 2 y1) of one image (input rows [y0, y1) of h x w) into `band`,
  // output_channels planes of 2 (y1 - y0) x 2w one after the other, activated.
  void run_2x2_band(const float* src, int h, int w, int y0, int y1, float* band,
                    const cv::dnn::ActivationLayer* activation);
  // narrow_2x2(): the whole output of input planes h x w, into dst planes `dst_plane` apart.
  void run_narrow(const float* src, int h, int w, float* dst, std::size_t dst_plane,
                  const cv::dnn::ActivationLayer* activation);

 private:
  struct Phase {
    int taps = 0;
    int shift_rows[4] = {}, shift_cols[4] = {};    // input offset (0 or 1) of each tap
    int kernel_rows[4] = {}, kernel_cols[4] = {};  // its place in the 3x3 kernel
    PackedWeights weights;
  };

  void pack(ProductBlock block);  // the weights for blocks of that shape
  void multiply(const Phase& phase, int block_begin, int block_end, float* out) const;
  // 2x2: a band of input rows at a time (its products stay in cache until interleaved).
  void run_2x2(const float* src, int h, int w, float* dst,
               const cv::dnn::ActivationLayer* activation);
  // For input rows y in [y0, y1): dst's plane c, row 2y + a takes phase (a, 0)'s and (a, 1)'s
  // row y in turn, from phase_row(phase, c, y); then the activation on those output rows.
  // `stream`: each plane's rows are put together in a small buffer and written past the caches
  // (dst's planes and rows keep the vectors 32-byte aligned).
  // 2x2: products_ = the four phases' products of input rows [y0, y0 + rows) (each phase's
  // cout_ planes of rows x w), read where they are where the product can, else copied first.
  void band_phase_products(const float* src, int h, int w, int y0, int rows);
  void interleave(int y0, int y1, int h, int w, float* dst,
                  const cv::dnn::ActivationLayer* activation,
                  const std::function<const float*(int, int, int)>& phase_row, bool stream = false);

  int kernel_;  // 3 or 2
  // 2x2 with at most this many outputs (PP-OCR's last layer, 24 -> 1): each output's four phases
  // summed in registers straight from the input, where the 1x1 product would pad its 4 x outputs
  // rows to a whole block and copy the input's bands.
  static constexpr int kNarrowOutputs = 2;
  // 2x2: the four phases as one 1x1 convolution of 4 x output channels, phase-major.
  std::unique_ptr<PointwiseConvolution> phases_2x2_;

  // The block shape the weights are packed for (chosen per input size: the least padding).
  int rows_per_block_ = 0, row_blocks_ = 0, lanes_per_block_ = 0;
  Phase phases_[4];  // (a, b) = (0, 0), (0, 1), (1, 0), (1, 1)
  // Per run: the input with a zero column and row after each plane (floats or bfloat16 pairs),
  // the four phase products.
  int padded_width_ = 0, columns_ = 0;
  ProductInput input_;
  std::vector<float> products_;
  std::vector<float> band_input_;  // 2x2, bfloat16: the input's band, channels contiguous
};

}  // namespace keyfleet::vision
