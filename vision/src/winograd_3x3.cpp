#include "winograd_3x3.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define KEYFLEET_WINOGRAD_X86 1
#endif

namespace keyfleet::vision {
namespace {

// The transformed input of a band takes about 0.6 MB (cin x blocks <= kBandValues, 36 floats
// each; 8192 measured about as fast on PP-OCR's detector, 16384 slower).
constexpr int kBandValues = 4096;

// Rows of blocks per band: as many as kBandValues allows, or up to twice that where more fill
// the product's column blocks with less padding (PP-OCR's detector at 640x480: 40 blocks across
// its 160 columns pad to 48 product columns, 17 % of the products wasted; two rows, 80, fill
// five blocks of 16: its two largest layers 0.91x on the AVX2 EPYC).
int band_rows(int cin, int cout, int across, int blocks_down) {
  const int budget = std::clamp(kBandValues / (cin * across), 1, blocks_down);
  int best = budget;
  double least = 0;
  for (int rows = budget; rows <= std::min(2 * budget, blocks_down); ++rows) {
    const int columns = rows * across;
    const ProductBlock block = float_product_block(cout, columns);
    const double padded = double(round_up(cout, block.rows)) * round_up(columns, block.columns) /
                          (double(cout) * columns);
    if (rows == budget || padded < least) best = rows, least = padded;
  }
  return best;
}

#ifdef KEYFLEET_WINOGRAD_X86
using Vec = __m256;

// The 32 floats at p as four vectors, each lane of vector k holding 4 floats of one block: lane 0
// of vector k block k's, lane 1 block k + 4's (columns 4 b .. 4 b + 3 are block b's).
__attribute__((target("avx2,fma"))) inline void lanes_of_blocks(const float* p, Vec a[4]) {
  const Vec lo = _mm256_loadu_ps(p), lo2 = _mm256_loadu_ps(p + 8);
  const Vec hi = _mm256_loadu_ps(p + 16), hi2 = _mm256_loadu_ps(p + 24);
  a[0] = _mm256_permute2f128_ps(lo, hi, 0x20);
  a[1] = _mm256_permute2f128_ps(lo, hi, 0x31);
  a[2] = _mm256_permute2f128_ps(lo2, hi2, 0x20);
  a[3] = _mm256_permute2f128_ps(lo2, hi2, 0x31);
}

// Columns 4 b + j (j < 4) of the 32 floats at p, for the 8 blocks b in their order (an in-lane
// 4x4 transpose of lanes_of_blocks). Every plane holds its blocks in that order, so 8 blocks
// stored from any column agree with the 8 stored before them where the two overlap.
__attribute__((target("avx2,fma"))) inline void columns_of_4(const float* p, Vec c[4]) {
  Vec a[4];
  lanes_of_blocks(p, a);
  const Vec t0 = _mm256_unpacklo_ps(a[0], a[1]), t1 = _mm256_unpackhi_ps(a[0], a[1]);
  const Vec t2 = _mm256_unpacklo_ps(a[2], a[3]), t3 = _mm256_unpackhi_ps(a[2], a[3]);
  c[0] = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
  c[1] = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
  c[2] = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
  c[3] = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
}

// Columns 4 b and 4 b + 1 only (the block's columns 4 and 5, read 4 further on).
__attribute__((target("avx2,fma"))) inline void columns_of_2(const float* p, Vec c[2]) {
  Vec a[4];
  lanes_of_blocks(p, a);
  const Vec t0 = _mm256_unpacklo_ps(a[0], a[1]), t2 = _mm256_unpacklo_ps(a[2], a[3]);
  c[0] = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
  c[1] = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
}

// B^T x along one direction, F(4x4, 3x3) (Lavin and Gray's B^T):
// (4 x0 - 5 x2 + x4, -4 x1 - 4 x2 + x3 + x4, 4 x1 - 4 x2 - x3 + x4, -2 x1 - x2 + 2 x3 + x4,
//  2 x1 - x2 - 2 x3 + x4, 4 x1 - 5 x3 + x5).
__attribute__((target("avx2,fma"))) inline void input_1d(const Vec* x, Vec* out) {
  const Vec four = _mm256_set1_ps(4.f), five = _mm256_set1_ps(5.f), two = _mm256_set1_ps(2.f);
  const Vec a = _mm256_fnmadd_ps(four, x[2], x[4]);  // x4 - 4 x2
  const Vec b = _mm256_fnmadd_ps(four, x[1], x[3]);  // x3 - 4 x1
  const Vec c = _mm256_sub_ps(x[4], x[2]);
  const Vec d = _mm256_mul_ps(two, _mm256_sub_ps(x[3], x[1]));
  out[0] = _mm256_fmadd_ps(four, x[0], _mm256_fnmadd_ps(five, x[2], x[4]));
  out[1] = _mm256_add_ps(a, b);
  out[2] = _mm256_sub_ps(a, b);
  out[3] = _mm256_add_ps(c, d);
  out[4] = _mm256_sub_ps(c, d);
  out[5] = _mm256_fmadd_ps(four, x[1], _mm256_fnmadd_ps(five, x[3], x[5]));
}

// The 36 transformed values of 8 blocks side by side, whose 6x6 patches start at `patch` (rows
// `width` apart, blocks 4 columns apart), stored 36 planes `plane` apart.
__attribute__((target("avx2,fma"))) void input_blocks(const float* patch, int width, float* out,
                                                      std::size_t plane) {
  Vec d[6][6], t[6][6];
  for (int r = 0; r < 6; ++r) {
    const float* row = patch + std::size_t(r) * width;
    columns_of_4(row, d[r]);
    columns_of_2(row + 4, d[r] + 4);
  }
  for (int j = 0; j < 6; ++j) {  // down each column
    const Vec column[6] = {d[0][j], d[1][j], d[2][j], d[3][j], d[4][j], d[5][j]};
    Vec done[6];
    input_1d(column, done);
    for (int i = 0; i < 6; ++i) t[i][j] = done[i];
  }
  for (int i = 0; i < 6; ++i) {  // along each row
    Vec done[6];
    input_1d(t[i], done);
    for (int j = 0; j < 6; ++j) _mm256_storeu_ps(out + (i * 6 + j) * plane, done[j]);
  }
}

// A^T m along one direction: (m0 + m1 + m2 + m3 + m4, m1 - m2 + 2 (m3 - m4),
// m1 + m2 + 4 (m3 + m4), m1 - m2 + 8 (m3 - m4) + m5).
__attribute__((target("avx2,fma"))) inline void output_1d(const Vec* m, Vec* out) {
  const Vec p = _mm256_add_ps(m[1], m[2]), q = _mm256_sub_ps(m[1], m[2]);
  const Vec r = _mm256_add_ps(m[3], m[4]), s = _mm256_sub_ps(m[3], m[4]);
  out[0] = _mm256_add_ps(_mm256_add_ps(m[0], p), r);
  out[1] = _mm256_fmadd_ps(_mm256_set1_ps(2.f), s, q);
  out[2] = _mm256_fmadd_ps(_mm256_set1_ps(4.f), r, p);
  out[3] = _mm256_add_ps(_mm256_fmadd_ps(_mm256_set1_ps(8.f), s, q), m[5]);
}

// A^T m A of 8 blocks (m: 36 planes `plane` apart, blocks in their order) plus the
// bias: y[r] holds output row r of the 8 blocks, 32 floats left to right.
__attribute__((target("avx2,fma"))) void output_blocks(const float* m, std::size_t plane,
                                                       float bias, float y[4][32]) {
  Vec s[4][6];
  for (int j = 0; j < 6; ++j) {  // down each column
    Vec column[6];
    for (int i = 0; i < 6; ++i) column[i] = _mm256_loadu_ps(m + (i * 6 + j) * plane);
    Vec done[4];
    output_1d(column, done);
    for (int r = 0; r < 4; ++r) s[r][j] = done[r];
  }
  const Vec b = _mm256_set1_ps(bias);
  for (int r = 0; r < 4; ++r) {  // along each row, then the blocks' 4 columns interleaved
    Vec c[4];
    output_1d(s[r], c);
    for (Vec& v : c) v = _mm256_add_ps(v, b);
    const Vec u0 = _mm256_unpacklo_ps(c[0], c[1]), u1 = _mm256_unpackhi_ps(c[0], c[1]);
    const Vec u2 = _mm256_unpacklo_ps(c[2], c[3]), u3 = _mm256_unpackhi_ps(c[2], c[3]);
    // Block k's 4 columns in lane 0 of b[k], block k + 4's in lane 1.
    const Vec b[4] = {_mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(1, 0, 1, 0)),
                      _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(3, 2, 3, 2)),
                      _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(1, 0, 1, 0)),
                      _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(3, 2, 3, 2))};
    _mm256_storeu_ps(y[r], _mm256_permute2f128_ps(b[0], b[1], 0x20));
    _mm256_storeu_ps(y[r] + 8, _mm256_permute2f128_ps(b[2], b[3], 0x20));
    _mm256_storeu_ps(y[r] + 16, _mm256_permute2f128_ps(b[0], b[1], 0x31));
    _mm256_storeu_ps(y[r] + 24, _mm256_permute2f128_ps(b[2], b[3], 0x31));
  }
}
#endif

}  // namespace

Winograd3x3::Winograd3x3(const cv::Mat& weights, const cv::Mat& bias)
    : cin_(weights.size[1]), cout_(weights.size[0]), bias_(padded_bias(bias, cout_)) {
  CV_Assert(weights.dims == 4 && weights.type() == CV_32F && weights.isContinuous() &&
            weights.size[2] == 3 && weights.size[3] == 3);
  // U = G g G^T, Lavin and Gray's G for F(4x4, 3x3), in double before rounding to float.
  constexpr double kG[6][3] = {{1 / 4.0, 0, 0},
                               {-1 / 6.0, -1 / 6.0, -1 / 6.0},
                               {-1 / 6.0, 1 / 6.0, -1 / 6.0},
                               {1 / 24.0, 1 / 12.0, 1 / 6.0},
                               {1 / 24.0, -1 / 12.0, 1 / 6.0},
                               {0, 0, 1}};
  transformed_.assign(std::size_t(kTaps) * cout_ * cin_, 0.f);
  for (int co = 0; co < cout_; ++co)
    for (int ci = 0; ci < cin_; ++ci) {
      const float* g = weights.ptr<float>() + (std::size_t(co) * cin_ + ci) * 9;
      double gg[6][3] = {};  // G g
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 3; ++k) gg[i][j] += kG[i][k] * g[k * 3 + j];
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
          double u = 0;
          for (int k = 0; k < 3; ++k) u += gg[i][k] * kG[j][k];
          transformed_[(std::size_t(i * 6 + j) * cout_ + co) * cin_ + ci] = float(u);
        }
    }
}

void Winograd3x3::pack(ProductBlock block) {
  block_ = block;
  row_blocks_ = (cout_ + block.rows - 1) / block.rows;
  packed_.pack(block, kTaps, cin_, cout_, false, [&](int co, int ci, int t) {
    return transformed_[(std::size_t(t) * cout_ + co) * cin_ + ci];
  });
}

void Winograd3x3::transform_input(const float* src, int h, int w, int ty0, int ty1) {
#ifdef KEYFLEET_WINOGRAD_X86
  // Block (ty, tx) reads source rows 4 ty - 1 .. 4 ty + 4 and columns 4 tx - 1 .. 4 tx + 4; 8
  // blocks from tx read 32 columns from 4 tx - 1 and 32 from 4 tx + 3: a band's rows of a channel
  // are copied with a zero border (a few KB, in L1) and read from there.
  const int width = 4 * blocks_across_ + 8, rows = 4 * (ty1 - ty0) + 2;
  const std::size_t plane = v_plane_;  // between the 36 transforms
  cv::parallel_for_(cv::Range(0, cin_), [&](const cv::Range& channels) {
    // A band's rows of a channel; its zero columns stay from one channel and band to the next.
    thread_local ZeroBorderedRows bordered;
    for (int c = channels.start; c < channels.end; ++c) {
      // Bordered row r is source row 4 ty0 - 1 + r, behind one zero column.
      const float* rows_of_band =
          bordered.fill(src + std::size_t(c) * h * w, h, w, 1 - 4 * ty0, 1, rows, width);
      for (int ty = ty0; ty < ty1; ++ty)
        for (int group = 0; group < blocks_across_; group += 8) {
          const int tx = group_start(group);
          input_blocks(
              rows_of_band + std::size_t(4 * (ty - ty0)) * width + 4 * tx, width,
              v_.data() + std::size_t(c) * columns_ + std::size_t(ty - ty0) * blocks_across_ + tx,
              plane);
        }
    }
  });
#else
  (void)src, (void)h, (void)w, (void)ty0, (void)ty1;
#endif
}

void Winograd3x3::multiply(int columns) {
  const int depth = summed_chunk(cin_, 1, block_.columns);
  const int zero_shift = 0;
  static const std::vector<float> zeros(64, 0.f);
  cv::parallel_for_(cv::Range(0, columns / block_.columns), [&](const cv::Range& blocks) {
    for (int t = 0; t < kTaps; ++t)
      for (int k0 = 0; k0 < cin_; k0 += depth) {
        const int k = std::min(depth, cin_ - k0);
        for (int blk = blocks.start; blk < blocks.end; ++blk) {
          const int n0 = blk * block_.columns;
          for (int rb = 0; rb < row_blocks_; ++rb) {
            const float* a =
                packed_.floats.data() + ((std::size_t(rb) * kTaps + t) * cin_ + k0) * block_.rows;
            const float* b = v_.data() + t * v_plane_ + std::size_t(k0) * columns_ + n0;
            float* out = m_.data() + t * m_plane_ + std::size_t(rb) * block_.rows * columns_ + n0;
            product_block(block_, 1, a, 0, b, &zero_shift, k, columns_,
                          k0 == 0 ? zeros.data() : nullptr, out, columns_);
          }
        }
      }
  });
}

void Winograd3x3::transform_output(int ty0, int ty1, int h, int w, float* dst,
                                   const cv::dnn::ActivationLayer* activation) {
#ifdef KEYFLEET_WINOGRAD_X86
  const std::size_t plane = m_plane_;  // between the 36 products
  const std::size_t out_plane = std::size_t(h) * w;
  cv::parallel_for_(cv::Range(0, cout_), [&](const cv::Range& channels) {
    float y[4][32];
    for (int co = channels.start; co < channels.end; ++co) {
      float* out = dst + co * out_plane;
      for (int ty = ty0; ty < ty1; ++ty)
        for (int group = 0; group < blocks_across_ && 4 * group < w; group += 8) {
          const int tx = group_start(group);
          output_blocks(
              m_.data() + std::size_t(co) * columns_ + std::size_t(ty - ty0) * blocks_across_ + tx,
              plane, bias_[std::size_t(co)], y);
          const int count = std::min(32, w - 4 * tx);
          for (int r = 0; r < 4 && 4 * ty + r < h; ++r)
            std::memcpy(out + std::size_t(4 * ty + r) * w + 4 * tx, y[r],
                        sizeof(float) * std::size_t(count));
        }
      if (activation) {
        const int first = 4 * ty0, last = std::min(h, 4 * ty1);
        float* rows = out + std::size_t(first) * w;
        activation->forwardSlice(rows, rows, (last - first) * w, out_plane, co, co + 1);
      }
    }
  });
#else
  (void)ty0, (void)ty1, (void)h, (void)w, (void)dst, (void)activation;
#endif
}

void Winograd3x3::run(const float* src, int h, int w, float* dst,
                      const cv::dnn::ActivationLayer* activation) {
  const int blocks_down = (h + 3) / 4;
  // The blocks of a row side by side, none padded in (PP-OCR's 80 columns: 20 blocks, not 24;
  // its 40: 10, not 16), at least the 8 the transforms take at a time.
  blocks_across_ = std::max(8, (w + 3) / 4);
  const int band = band_rows(cin_, cout_, blocks_across_, blocks_down);
  const ProductBlock block = float_product_block(cout_, band * blocks_across_);
  if (block.rows != block_.rows || block.columns != block_.columns) pack(block);
  columns_ = round_up(band * blocks_across_, block_.columns);
  // The 36 planes of each a cache line more than their size apart: at sizes of a multiple of
  // 4 KB (96 x 160 floats) the stores of a block would all fall in one set of L1's.
  v_plane_ = std::size_t(cin_) * columns_ + 16;
  m_plane_ = std::size_t(row_blocks_) * block_.rows * columns_ + 16;
  v_.resize(kTaps * v_plane_);
  m_.resize(kTaps * m_plane_);
  for (int ty0 = 0; ty0 < blocks_down; ty0 += band) {
    const int ty1 = std::min(blocks_down, ty0 + band);
    transform_input(src, h, w, ty0, ty1);
    multiply(round_up((ty1 - ty0) * blocks_across_, block_.columns));
    transform_output(ty0, ty1, h, w, dst, activation);
  }
}

}  // namespace keyfleet::vision
