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

// The transformed input of a band takes about 1 MB (cin x blocks <= kBandValues, 16 floats each).
constexpr int kBandValues = 16384;

#ifdef KEYFLEET_WINOGRAD_X86
using Vec = __m256;

// Elements 0, 2, .., 14 and 1, 3, .., 15 of the 16 floats at p.
__attribute__((target("avx2,fma"))) inline void even_odd(const float* p, Vec& even, Vec& odd) {
  const Vec lo = _mm256_loadu_ps(p), hi = _mm256_loadu_ps(p + 8);
  const Vec e = _mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0));
  const Vec o = _mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(3, 1, 3, 1));
  even = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(e), _MM_SHUFFLE(3, 1, 2, 0)));
  odd = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(o), _MM_SHUFFLE(3, 1, 2, 0)));
}

// B^T x B along one direction: (x0 - x2, x1 + x2, x2 - x1, x1 - x3).
__attribute__((target("avx2,fma"))) inline void input_1d(const Vec* x, Vec* out) {
  out[0] = _mm256_sub_ps(x[0], x[2]);
  out[1] = _mm256_add_ps(x[1], x[2]);
  out[2] = _mm256_sub_ps(x[2], x[1]);
  out[3] = _mm256_sub_ps(x[1], x[3]);
}

// The 16 transformed values of 8 blocks side by side, whose 4x4 patches start at `patch` (rows
// `width` apart, blocks 2 columns apart), stored 16 planes `plane` apart.
__attribute__((target("avx2,fma"))) void input_blocks(const float* patch, int width, float* out,
                                                      std::size_t plane) {
  Vec d[4][4], t[4][4];
  for (int r = 0; r < 4; ++r) {
    const float* row = patch + std::size_t(r) * width;
    even_odd(row, d[r][0], d[r][1]);
    even_odd(row + 2, d[r][2], d[r][3]);
  }
  for (int j = 0; j < 4; ++j) {  // down each column
    const Vec column[4] = {d[0][j], d[1][j], d[2][j], d[3][j]};
    Vec done[4];
    input_1d(column, done);
    for (int i = 0; i < 4; ++i) t[i][j] = done[i];
  }
  for (int i = 0; i < 4; ++i) {  // along each row
    Vec done[4];
    input_1d(t[i], done);
    for (int j = 0; j < 4; ++j) _mm256_storeu_ps(out + (i * 4 + j) * plane, done[j]);
  }
}

// A^T m A of 8 blocks (m: 16 planes `plane` apart) plus the bias: y[r] holds output row r of the
// blocks, their two columns interleaved (16 floats).
__attribute__((target("avx2,fma"))) void output_blocks(const float* m, std::size_t plane,
                                                       float bias, float y[2][16]) {
  Vec v[4][4];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) v[i][j] = _mm256_loadu_ps(m + (i * 4 + j) * plane);
  Vec s[2][4];
  for (int j = 0; j < 4; ++j) {
    s[0][j] = _mm256_add_ps(_mm256_add_ps(v[0][j], v[1][j]), v[2][j]);
    s[1][j] = _mm256_sub_ps(_mm256_sub_ps(v[1][j], v[2][j]), v[3][j]);
  }
  const Vec b = _mm256_set1_ps(bias);
  for (int r = 0; r < 2; ++r) {
    const Vec left = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(s[r][0], s[r][1]), s[r][2]), b);
    const Vec right = _mm256_add_ps(_mm256_sub_ps(_mm256_sub_ps(s[r][1], s[r][2]), s[r][3]), b);
    const Vec lo = _mm256_unpacklo_ps(left, right), hi = _mm256_unpackhi_ps(left, right);
    _mm256_storeu_ps(y[r], _mm256_permute2f128_ps(lo, hi, 0x20));
    _mm256_storeu_ps(y[r] + 8, _mm256_permute2f128_ps(lo, hi, 0x31));
  }
}
#endif

}  // namespace

Winograd3x3::Winograd3x3(const cv::Mat& weights, const cv::Mat& bias)
    : cin_(weights.size[1]), cout_(weights.size[0]), bias_(padded_bias(bias, cout_)) {
  CV_Assert(weights.dims == 4 && weights.type() == CV_32F && weights.isContinuous() &&
            weights.size[2] == 3 && weights.size[3] == 3);
  // U = G g G^T, G = [1 0 0; 1/2 1/2 1/2; 1/2 -1/2 1/2; 0 0 1].
  constexpr float kG[4][3] = {{1, 0, 0}, {0.5f, 0.5f, 0.5f}, {0.5f, -0.5f, 0.5f}, {0, 0, 1}};
  transformed_.assign(std::size_t(16) * cout_ * cin_, 0.f);
  for (int co = 0; co < cout_; ++co)
    for (int ci = 0; ci < cin_; ++ci) {
      const float* g = weights.ptr<float>() + (std::size_t(co) * cin_ + ci) * 9;
      float gg[4][3] = {};  // G g
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 3; ++k) gg[i][j] += kG[i][k] * g[k * 3 + j];
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
          float u = 0.f;
          for (int k = 0; k < 3; ++k) u += gg[i][k] * kG[j][k];
          transformed_[(std::size_t(i * 4 + j) * cout_ + co) * cin_ + ci] = u;
        }
    }
}

void Winograd3x3::pack(ProductBlock block) {
  block_ = block;
  row_blocks_ = (cout_ + block.rows - 1) / block.rows;
  packed_.pack(block, 16, cin_, cout_, false, [&](int co, int ci, int t) {
    return transformed_[(std::size_t(t) * cout_ + co) * cin_ + ci];
  });
}

void Winograd3x3::transform_input(const float* src, int h, int w, int ty0, int ty1) {
#ifdef KEYFLEET_WINOGRAD_X86
  // Block (ty, tx) reads source rows 2 ty - 1 .. 2 ty + 2 and columns 2 tx - 1 .. 2 tx + 16 (its
  // vectors of 16 at 2 tx - 1 and 2 tx + 1): a band's rows of a channel are copied with a zero
  // border (a few KB, in L1) and read from there.
  const int width = 2 * blocks_across_ + 2, rows = 2 * (ty1 - ty0) + 2;
  const std::size_t plane = v_plane_;  // between the 16 transforms
  cv::parallel_for_(cv::Range(0, cin_), [&](const cv::Range& channels) {
    thread_local std::vector<float> bordered;
    bordered.resize(std::size_t(rows) * width);
    for (int c = channels.start; c < channels.end; ++c) {
      // Bordered row r is source row 2 ty0 - 1 + r, behind one zero column.
      copy_with_zero_border(src + std::size_t(c) * h * w, h, w, 1 - 2 * ty0, 1, rows, width,
                            bordered.data());
      for (int ty = ty0; ty < ty1; ++ty)
        for (int tx = 0; tx < blocks_across_; tx += 8)
          input_blocks(
              bordered.data() + std::size_t(2 * (ty - ty0)) * width + 2 * tx, width,
              v_.data() + std::size_t(c) * columns_ + std::size_t(ty - ty0) * blocks_across_ + tx,
              plane);
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
    for (int t = 0; t < 16; ++t)
      for (int k0 = 0; k0 < cin_; k0 += depth) {
        const int k = std::min(depth, cin_ - k0);
        for (int blk = blocks.start; blk < blocks.end; ++blk) {
          const int n0 = blk * block_.columns;
          for (int rb = 0; rb < row_blocks_; ++rb) {
            const float* a =
                packed_.floats.data() + ((std::size_t(rb) * 16 + t) * cin_ + k0) * block_.rows;
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
  const std::size_t plane = m_plane_;  // between the 16 products
  const std::size_t out_plane = std::size_t(h) * w;
  cv::parallel_for_(cv::Range(0, cout_), [&](const cv::Range& channels) {
    float y[2][16];
    for (int co = channels.start; co < channels.end; ++co) {
      float* out = dst + co * out_plane;
      for (int ty = ty0; ty < ty1; ++ty)
        for (int tx = 0; tx < blocks_across_ && 2 * tx < w; tx += 8) {
          output_blocks(
              m_.data() + std::size_t(co) * columns_ + std::size_t(ty - ty0) * blocks_across_ + tx,
              plane, bias_[std::size_t(co)], y);
          const int count = std::min(16, w - 2 * tx);
          for (int r = 0; r < 2 && 2 * ty + r < h; ++r)
            std::memcpy(out + std::size_t(2 * ty + r) * w + 2 * tx, y[r],
                        sizeof(float) * std::size_t(count));
        }
      if (activation) {
        const int first = 2 * ty0, last = std::min(h, 2 * ty1);
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
  const int blocks_down = (h + 1) / 2;
  blocks_across_ = ((w + 1) / 2 + 7) / 8 * 8;
  const int band = std::clamp(kBandValues / (cin_ * blocks_across_), 1, blocks_down);
  const ProductBlock block = float_product_block(cout_, band * blocks_across_);
  if (block.rows != block_.rows || block.columns != block_.columns) pack(block);
  columns_ = round_up(band * blocks_across_, block_.columns);
  // The 16 planes of each a cache line more than their size apart: at sizes of a multiple of
  // 4 KB (96 x 160 floats) the 16 stores of a block would all fall in one set of L1's.
  v_plane_ = std::size_t(cin_) * columns_ + 16;
  m_plane_ = std::size_t(row_blocks_) * block_.rows * columns_ + 16;
  v_.resize(16 * v_plane_);
  m_.resize(16 * m_plane_);
  for (int ty0 = 0; ty0 < blocks_down; ty0 += band) {
    const int ty1 = std::min(blocks_down, ty0 + band);
    transform_input(src, h, w, ty0, ty1);
    multiply(round_up((ty1 - ty0) * blocks_across_, block_.columns));
    transform_output(ty0, ty1, h, w, dst, activation);
  }
}

}  // namespace keyfleet::vision
