#include "subpixel_deconvolution.hpp"

#include <opencv2/core/hal/intrin.hpp>

#include <algorithm>
#include <utility>
#include <vector>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

namespace keyfleet::vision {
namespace {

// Along one direction, output phase 0 (even) meets kernel tap 1 at input offset 0; phase 1
// (odd) meets tap 2 at offset 0 and tap 0 at offset 1.
struct Tap {
  int offset, tap;
};
constexpr Tap kPhase0[] = {{0, 1}};
constexpr Tap kPhase1[] = {{0, 2}, {1, 0}};

int kernel_of(const cv::Mat& weights) { return weights.dims == 4 ? weights.size[2] : 0; }

// The 2x2 kernel's phases as 1x1 weights: output (a * 2 + b) * cout + co, input ci is tap (a, b)
// of input ci to output co; the bias repeated for each phase.
std::pair<cv::Mat, cv::Mat> phases_as_pointwise(const cv::Mat& weights, const cv::Mat& bias) {
  const int cin = weights.size[0], cout = weights.size[1];
  cv::Mat w({4 * cout, cin, 1, 1}, CV_32F), b;
  const float* from = weights.ptr<float>();  // [cin][cout][2][2]
  float* to = w.ptr<float>();
  for (int p = 0; p < 4; ++p)
    for (int co = 0; co < cout; ++co)
      for (int ci = 0; ci < cin; ++ci)
        to[(std::size_t(p) * cout + co) * cin + ci] = from[(std::size_t(ci) * cout + co) * 4 + p];
  if (!bias.empty()) {
    b.create(1, 4 * cout, CV_32F);
    for (int p = 0; p < 4; ++p)
      std::copy_n(bias.ptr<float>(), cout, b.ptr<float>() + std::size_t(p) * cout);
  }
  return {w, b};
}

#if defined(__GNUC__) && defined(__x86_64__)
// Two vectors of one output row's even (e) and odd (o) columns, 8 of each, stored interleaved.
__attribute__((target("avx2,fma"))) inline void store_zipped(float* row, __m256 e, __m256 o) {
  const __m256 lo = _mm256_unpacklo_ps(e, o), hi = _mm256_unpackhi_ps(e, o);
  _mm256_storeu_ps(row, _mm256_permute2f128_ps(lo, hi, 0x20));
  _mm256_storeu_ps(row + 8, _mm256_permute2f128_ps(lo, hi, 0x31));
}

// Output channel co of a 2x2 stride-2 transposed convolution for input rows [y0, y1): output
// (2 y + a, 2 x + b) = bias + sum over ci of w[ci][co][a][b] in[ci][y][x], 16 input columns at a
// time summed in registers (the four phases of two vectors), then the activation on those rows.
__attribute__((target("avx2,fma"))) void narrow_2x2_rows(
    const float* src, int cin, int h, int w, const float* weights, int cout, int co, float bias,
    int y0, int y1, float* dst, std::size_t out_plane, const cv::dnn::ActivationLayer* activation) {
  const std::size_t plane = std::size_t(h) * w;
  float* out = dst + co * out_plane;
  for (int y = y0; y < y1; ++y) {
    float* row0 = out + std::size_t(2 * y) * 2 * w;
    float* row1 = row0 + 2 * w;
    const float* in = src + std::size_t(y) * w;
    int x = 0;
    for (; x + 16 <= w; x += 16) {
      __m256 s[8];
      for (__m256& v : s) v = _mm256_set1_ps(bias);
      for (int ci = 0; ci < cin; ++ci) {
        const float* wt = weights + (std::size_t(ci) * cout + co) * 4;
        const __m256 v0 = _mm256_loadu_ps(in + ci * plane + x);
        const __m256 v1 = _mm256_loadu_ps(in + ci * plane + x + 8);
        for (int p = 0; p < 4; ++p) {
          const __m256 k = _mm256_broadcast_ss(wt + p);
          s[p] = _mm256_fmadd_ps(k, v0, s[p]);
          s[4 + p] = _mm256_fmadd_ps(k, v1, s[4 + p]);
        }
      }
      store_zipped(row0 + 2 * x, s[0], s[1]);
      store_zipped(row1 + 2 * x, s[2], s[3]);
      store_zipped(row0 + 2 * x + 16, s[4], s[5]);
      store_zipped(row1 + 2 * x + 16, s[6], s[7]);
    }
    for (; x < w; ++x) {
      float sum[4] = {bias, bias, bias, bias};
      for (int ci = 0; ci < cin; ++ci)
        for (int p = 0; p < 4; ++p)
          sum[p] += weights[(std::size_t(ci) * cout + co) * 4 + p] * in[ci * plane + x];
      row0[2 * x] = sum[0], row0[2 * x + 1] = sum[1];
      row1[2 * x] = sum[2], row1[2 * x + 1] = sum[3];
    }
  }
  if (activation) {
    float* rows = out + std::size_t(2 * y0) * 2 * w;
    activation->forwardSlice(rows, rows, 4 * (y1 - y0) * w, out_plane, co, co + 1);
  }
}
#endif

}  // namespace

bool SubpixelDeconvolution::supported() { return product_supported(); }

SubpixelDeconvolution::SubpixelDeconvolution(const cv::Mat& weights, const cv::Mat& bias,
                                             bool bfloat16)
    // The 2x2 geometry stays in float: in bfloat16 PP-OCR's DB head moved the agent's text IoU
    // on unseen photos by 1.8 points (test_clean, 320x256), for a layer that costs little.
    : ProductKernel(weights, bias, bfloat16 && kernel_of(weights) == 3, kernel_of(weights), true),
      kernel_(kernel_of(weights)) {
  CV_Assert(kernel_ == 2 || kernel_ == 3);
  if (kernel_ == 2) {
    const auto [w, b] = phases_as_pointwise(weights, bias);
    phases_2x2_ = std::make_unique<PointwiseConvolution>(w, b, bfloat16_);
    return;
  }
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      Phase& phase = phases_[a * 2 + b];
      const Tap* rows = a ? kPhase1 : kPhase0;
      const Tap* cols = b ? kPhase1 : kPhase0;
      const int col_taps = b ? 2 : 1;
      phase.taps = (a ? 2 : 1) * col_taps;
      for (int t = 0; t < phase.taps; ++t) {
        phase.shift_rows[t] = rows[t / col_taps].offset;
        phase.shift_cols[t] = cols[t % col_taps].offset;
        phase.kernel_rows[t] = rows[t / col_taps].tap;
        phase.kernel_cols[t] = cols[t % col_taps].tap;
      }
    }
}

void SubpixelDeconvolution::pack(ProductBlock block) {
  rows_per_block_ = block.rows;
  lanes_per_block_ = block.columns;
  row_blocks_ = (cout_ + block.rows - 1) / block.rows;
  const float* w = weights_.ptr<float>();  // [cin][cout][3][3]
  for (Phase& phase : phases_)
    phase.weights.pack(block, phase.taps, cin_, cout_, bfloat16_, [&](int co, int ci, int t) {
      return w[((std::size_t(ci) * cout_ + co) * 3 + phase.kernel_rows[t]) * 3 +
               phase.kernel_cols[t]];
    });
}

void SubpixelDeconvolution::multiply(const Phase& phase, int block_begin, int block_end,
                                     float* out) const {
  const int total = summed(), depth = summed_chunk(total, phase.taps, lanes_per_block_);
  int shifts[4];
  for (int t = 0; t < phase.taps; ++t)
    shifts[t] = phase.shift_rows[t] * padded_width_ + phase.shift_cols[t];
  const ProductBlock shape{rows_per_block_, lanes_per_block_};
  const std::size_t tap_stride = std::size_t(total) * shape.rows;
  for (int k0 = 0; k0 < total; k0 += depth) {
    const int k = std::min(depth, total - k0);
    for (int block = block_begin; block < block_end; ++block) {
      const int n0 = block * lanes_per_block_;
      for (int rb = 0; rb < row_blocks_; ++rb) {
        const std::size_t a = (std::size_t(rb) * phase.taps * total + k0) * shape.rows;
        const float* bias = k0 == 0 ? bias_.data() + rb * shape.rows : nullptr;
        float* o = out + std::size_t(rb) * shape.rows * columns_ + n0;
        input_.multiply(shape, phase.taps, phase.weights, a, tap_stride, k0, n0, shifts, k, bias, o,
                        columns_);
      }
    }
  }
}

void SubpixelDeconvolution::run(const float* src, int h, int w, float* dst,
                                const cv::dnn::ActivationLayer* activation) {
  if (kernel_ == 2) {
    run_2x2(src, h, w, dst, activation);
    return;
  }
  // Each plane gets a zero column and a zero row after it (what the taps at offset 1 read past
  // the input's edge) and the columns a last block reads beyond that; products are computed on
  // the padded width (the extra column's results are dropped).
  padded_width_ = w + 1;
  const ProductBlock block = bfloat16_ ? bf16_product_block(cout_, h * padded_width_)
                                       : float_product_block(cout_, h * padded_width_);
  if (block.rows != rows_per_block_) pack(block);
  columns_ = round_up(h * padded_width_, lanes_per_block_);
  input_.fill(src, cin_, h, w, bfloat16_, round_up(columns_ + padded_width_ + 1, 16),
              padded_width_);
  const std::size_t phase_size = std::size_t(row_blocks_) * rows_per_block_ * columns_;
  products_.resize(4 * phase_size);
  cv::parallel_for_(cv::Range(0, columns_ / lanes_per_block_), [&](const cv::Range& blocks) {
    for (int p = 0; p < 4; ++p)
      multiply(phases_[p], blocks.start, blocks.end, products_.data() + p * phase_size);
  });
  interleave(0, h, h, w, dst, activation, [&](int phase, int c, int y) {
    return products_.data() + phase * phase_size + std::size_t(c) * columns_ +
           std::size_t(y) * padded_width_;
  });
}

void SubpixelDeconvolution::run_2x2(const float* src, int h, int w, float* dst,
                                    const cv::dnn::ActivationLayer* activation) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (cout_ <= kNarrowOutputs) {
    CV_Assert(weights_.isContinuous() && weights_.type() == CV_32F);
    // Bands of 8 input rows (16 output rows of each output plane, in cache for the activation).
    const int bands = (h + 7) / 8;
    cv::parallel_for_(cv::Range(0, bands * cout_), [&](const cv::Range& range) {
      for (int i = range.start; i < range.end; ++i) {
        const int co = i / bands, y0 = (i % bands) * 8;
        narrow_2x2_rows(src, cin_, h, w, weights_.ptr<float>(), cout_, co, bias_[std::size_t(co)],
                        y0, std::min(h, y0 + 8), dst, std::size_t(4) * h * w, activation);
      }
    });
    return;
  }
#endif
  // Bands of input rows whose four phase products take about 512 KB (within L2): written and
  // read back in cache, where whole planes (7 MB for PP-OCR's first 2x2 layer at 640x480) went to
  // memory and back.
  constexpr int kBandFloats = 128 * 1024;
  const int band = std::clamp(kBandFloats / (4 * cout_ * w), 1, h);
  const std::size_t plane = std::size_t(h) * w;
  // A large output (PP-OCR's 24 -> 24 at 640x480: 7.4 MB) is written past the caches: its lines
  // need not be read in before they are written.
  const bool stream = std::size_t(4) * cout_ * plane * sizeof(float) >= kStreamedOutputBytes &&
                      w % 2 == 0 && vector_aligned(dst);
  for (int y0 = 0; y0 < h; y0 += band) {
    const int rows = std::min(band, h - y0);
    const std::size_t pixels = std::size_t(rows) * w;
    band_phase_products(src, h, w, y0, rows);
    interleave(
        y0, y0 + rows, h, w, dst, activation,
        [&](int phase, int c, int y) {
          return products_.data() + (std::size_t(phase) * cout_ + c) * pixels +
                 std::size_t(y - y0) * w;
        },
        stream);
  }
}

void SubpixelDeconvolution::band_phase_products(const float* src, int h, int w, int y0, int rows) {
  const std::size_t plane = std::size_t(h) * w, pixels = std::size_t(rows) * w;
  products_.resize(std::size_t(4) * cout_ * pixels);
  if (phases_2x2_->runs_columns()) {
    phases_2x2_->run_columns(src + std::size_t(y0) * w, plane, int(pixels), products_.data(),
                             pixels, nullptr);
    return;
  }
  band_input_.resize(std::size_t(cin_) * pixels);
  for (int c = 0; c < cin_; ++c)
    std::copy_n(src + c * plane + std::size_t(y0) * w, pixels, band_input_.data() + c * pixels);
  phases_2x2_->run(band_input_.data(), int(pixels), products_.data(), nullptr);
}

void SubpixelDeconvolution::run_2x2_band(const float* src, int h, int w, int y0, int y1,
                                         float* band, const cv::dnn::ActivationLayer* activation) {
  CV_Assert(kernel_ == 2 && cout_ > kNarrowOutputs && 0 <= y0 && y0 < y1 && y1 <= h);
  const int rows = y1 - y0;
  const std::size_t pixels = std::size_t(rows) * w;
  band_phase_products(src, h, w, y0, rows);
  // The band's output as an image of its own: `rows` input rows, planes 4 rows w apart.
  interleave(0, rows, rows, w, band, activation, [&](int phase, int c, int y) {
    return products_.data() + (std::size_t(phase) * cout_ + c) * pixels + std::size_t(y) * w;
  });
}

void SubpixelDeconvolution::run_narrow(const float* src, int h, int w, float* dst,
                                       std::size_t dst_plane,
                                       const cv::dnn::ActivationLayer* activation) {
  CV_Assert(kernel_ == 2 && cout_ <= kNarrowOutputs && weights_.isContinuous());
#if defined(__GNUC__) && defined(__x86_64__)
  for (int co = 0; co < cout_; ++co)
    narrow_2x2_rows(src, cin_, h, w, weights_.ptr<float>(), cout_, co, bias_[std::size_t(co)], 0, h,
                    dst, dst_plane, activation);
#else
  (void)src, (void)h, (void)w, (void)dst, (void)dst_plane, (void)activation;
#endif
}

void SubpixelDeconvolution::interleave(int y0, int y1, int h, int w, float* dst,
                                       const cv::dnn::ActivationLayer* activation,
                                       const std::function<const float*(int, int, int)>& phase_row,
                                       bool stream) {
  const std::size_t out_plane = std::size_t(4) * h * w;
  const int length = 4 * (y1 - y0) * w;  // a plane's output rows for these input rows
  cv::parallel_for_(cv::Range(0, cout_), [&](const cv::Range& channels) {
    thread_local std::vector<float> buffer;
    if (stream) buffer.resize(std::size_t(length));
    for (int c = channels.start; c < channels.end; ++c) {
      float* const dst_rows = dst + c * out_plane + std::size_t(2 * y0) * 2 * w;
      float* const rows = stream ? buffer.data() : dst_rows;
      for (int y = y0; y < y1; ++y)
        for (int a = 0; a < 2; ++a) {
          const float* even = phase_row(2 * a, c, y);
          const float* odd = phase_row(2 * a + 1, c, y);
          float* row = rows + std::size_t(2 * (y - y0) + a) * 2 * w;
          int x = 0;
          for (; x + 4 <= w; x += 4) {
            cv::v_float32x4 lo, hi;
            cv::v_zip(cv::v_load(even + x), cv::v_load(odd + x), lo, hi);
            cv::v_store(row + 2 * x, lo);
            cv::v_store(row + 2 * x + 4, hi);
          }
          for (; x < w; ++x) {
            row[2 * x] = even[x];
            row[2 * x + 1] = odd[x];
          }
        }
      if (activation) activation->forwardSlice(rows, rows, length, out_plane, c, c + 1);
      if (stream) stream_floats(rows, dst_rows, length);
    }
    if (stream) stores_fence();  // the streamed lines visible before the layer ends
  });
}

}  // namespace keyfleet::vision
