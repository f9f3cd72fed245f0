#include "depthwise_avx2.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <vector>

#include "product_operands.hpp"

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define KEYFLEET_DEPTHWISE_X86 1
#endif

namespace keyfleet::vision {
namespace {

#ifdef KEYFLEET_DEPTHWISE_X86
struct Tap {
  int offset;  // of the tap's input in the bordered plane, from the output's position
  float weight;
};

// Output columns [x, x + 8 * kVectors) of kRows rows whose taps start at `in` (rows `in_row`
// floats apart in the input, `out_row` in the output); the last vector of each row stores only
// `last_lanes` of its columns (8: all). Each output is the bias plus its taps in order, whatever
// kRows: two rows at a time give eight independent sums, enough to keep both FMA units busy
// (one row of four waited on each sum's previous product).
template <int kRows, int kVectors>
__attribute__((target("avx2,fma"))) inline void vectors(const Tap* taps, int tap_count,
                                                        const float* in, std::size_t in_row,
                                                        float bias, float* out, std::size_t out_row,
                                                        int last_lanes) {
  __m256 sum[kRows][kVectors];
  for (int r = 0; r < kRows; ++r)
    for (int v = 0; v < kVectors; ++v) sum[r][v] = _mm256_set1_ps(bias);
  for (int t = 0; t < tap_count; ++t) {
    const __m256 weight = _mm256_set1_ps(taps[t].weight);
    const float* s = in + taps[t].offset;
    for (int r = 0; r < kRows; ++r)
      for (int v = 0; v < kVectors; ++v)
        sum[r][v] = _mm256_fmadd_ps(weight, _mm256_loadu_ps(s + r * in_row + 8 * v), sum[r][v]);
  }
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(last_lanes), lanes);
  for (int r = 0; r < kRows; ++r) {
    float* o = out + r * out_row;
    for (int v = 0; v + 1 < kVectors; ++v) _mm256_storeu_ps(o + 8 * v, sum[r][v]);
    if (last_lanes == 8)
      _mm256_storeu_ps(o + 8 * (kVectors - 1), sum[r][kVectors - 1]);
    else
      _mm256_maskstore_ps(o + 8 * (kVectors - 1), mask, sum[r][kVectors - 1]);
  }
}

// kRows output rows from `in`/`out`: whole blocks of 32 columns, then the rest in one call.
template <int kRows>
__attribute__((target("avx2,fma"))) inline void output_rows(const Tap* taps, int tap_count,
                                                            const float* in, std::size_t in_row,
                                                            float bias, float* out,
                                                            std::size_t out_row, int wo) {
  int x = 0;
  for (; x + 32 <= wo; x += 32)
    vectors<kRows, 4>(taps, tap_count, in + x, in_row, bias, out + x, out_row, 8);
  const int rest = wo - x;
  if (rest <= 0) return;
  const int last = rest - (rest - 1) / 8 * 8;  // the last vector's columns, 1..8
  switch ((rest + 7) / 8) {
    case 1: vectors<kRows, 1>(taps, tap_count, in + x, in_row, bias, out + x, out_row, last); break;
    case 2: vectors<kRows, 2>(taps, tap_count, in + x, in_row, bias, out + x, out_row, last); break;
    case 3: vectors<kRows, 3>(taps, tap_count, in + x, in_row, bias, out + x, out_row, last); break;
    default: vectors<kRows, 4>(taps, tap_count, in + x, in_row, bias, out + x, out_row, last);
  }
}

// kRows output rows (stride kSh down columns) x (8 kVectors) columns of a kH x kw kernel
// without dilation, each input vector loaded once for every output row it feeds: for each
// kernel column, the kH weights stay in registers and the input rows the block reads are loaded
// in turn, each added to the rows it lies under. Outputs are the bias plus their taps summed
// column by column of the kernel (kx, then ky). `in`: the block's first input row at the block's
// first column; column_offsets[kx]: where kernel column kx reads from there; the last vector of
// each row stores `last_lanes` columns (8: all).
template <int kH, int kSh, int kRows, int kVectors>
__attribute__((target("avx2,fma"))) inline void reused_rows(const float* weights, int kw,
                                                            const int* column_offsets,
                                                            const float* in, std::size_t in_row,
                                                            float bias, float* out,
                                                            std::size_t out_row, int last_lanes) {
  constexpr int kInputRows = (kRows - 1) * kSh + kH;
  __m256 sum[kRows][kVectors];
#pragma GCC unroll 4
  for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 2
    for (int v = 0; v < kVectors; ++v) sum[r][v] = _mm256_set1_ps(bias);
  for (int kx = 0; kx < kw; ++kx) {
    __m256 w[kH];
#pragma GCC unroll 8
    for (int ky = 0; ky < kH; ++ky) w[ky] = _mm256_set1_ps(weights[ky * kw + kx]);
    const float* column = in + column_offsets[kx];
#pragma GCC unroll 16
    for (int i = 0; i < kInputRows; ++i) {
      __m256 x[kVectors];
#pragma GCC unroll 2
      for (int v = 0; v < kVectors; ++v) x[v] = _mm256_loadu_ps(column + i * in_row + 8 * v);
#pragma GCC unroll 4
      for (int r = 0; r < kRows; ++r) {
        const int ky = i - r * kSh;
        if (ky < 0 || ky >= kH) continue;
#pragma GCC unroll 2
        for (int v = 0; v < kVectors; ++v) sum[r][v] = _mm256_fmadd_ps(w[ky], x[v], sum[r][v]);
      }
    }
  }
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(last_lanes), lanes);
#pragma GCC unroll 4
  for (int r = 0; r < kRows; ++r) {
    float* o = out + r * out_row;
    if (kVectors == 2) _mm256_storeu_ps(o, sum[r][0]);
    if (last_lanes == 8)
      _mm256_storeu_ps(o + 8 * (kVectors - 1), sum[r][kVectors - 1]);
    else
      _mm256_maskstore_ps(o + 8 * (kVectors - 1), mask, sum[r][kVectors - 1]);
  }
}

// kRows output rows of the plane by reused_rows: blocks of 16 columns, then the rest.
template <int kH, int kSh, int kRows>
__attribute__((target("avx2,fma"))) void reused_output_rows(const float* weights, int kw,
                                                            const int* column_offsets,
                                                            const float* in, std::size_t in_row,
                                                            float bias, float* out,
                                                            std::size_t out_row, int wo) {
  int x = 0;
  for (; x + 16 <= wo; x += 16)
    reused_rows<kH, kSh, kRows, 2>(weights, kw, column_offsets, in + x, in_row, bias, out + x,
                                   out_row, 8);
  const int rest = wo - x;
  if (rest > 8)
    reused_rows<kH, kSh, kRows, 2>(weights, kw, column_offsets, in + x, in_row, bias, out + x,
                                   out_row, rest - 8);
  else if (rest > 0)
    reused_rows<kH, kSh, kRows, 1>(weights, kw, column_offsets, in + x, in_row, bias, out + x,
                                   out_row, rest);
}

// The whole plane by reused_output_rows, four rows at a time.
template <int kH, int kSh>
__attribute__((target("avx2,fma"))) void reused_plane(const float* weights, int kw,
                                                      const int* column_offsets, const float* plane,
                                                      std::size_t row, float bias, float* dst,
                                                      int ho, int wo) {
  const std::size_t in_row = std::size_t(kSh) * row, out_row = std::size_t(wo);
  int y = 0;
  for (; y + 4 <= ho; y += 4)
    reused_output_rows<kH, kSh, 4>(weights, kw, column_offsets, plane + y * in_row, row, bias,
                                   dst + y * out_row, out_row, wo);
  const float* in = plane + y * in_row;
  float* out = dst + y * out_row;
  switch (ho - y) {
    case 3:
      reused_output_rows<kH, kSh, 3>(weights, kw, column_offsets, in, row, bias, out, out_row, wo);
      break;
    case 2:
      reused_output_rows<kH, kSh, 2>(weights, kw, column_offsets, in, row, bias, out, out_row, wo);
      break;
    case 1:
      reused_output_rows<kH, kSh, 1>(weights, kw, column_offsets, in, row, bias, out, out_row, wo);
      break;
    default: break;
  }
}

// The plane with a zero border (pt rows above, pl columns left) as two planes of `row` floats a
// row, its even columns then its odd ones, in one pass from src.
__attribute__((target("avx2,fma"))) void bordered_phases(const float* src, int h, int w, int pt,
                                                         int pl, int height, int row, float* out) {
  float* even = out;
  float* odd = out + std::size_t(height) * row;
  // Source column c lands at bordered column c + pl, which is column (c + pl) / 2 of the even
  // plane where c + pl is even, else of the odd one.
  for (int r = 0; r < height; ++r) {
    float* e = even + std::size_t(r) * row;
    float* o = odd + std::size_t(r) * row;
    std::fill(e, e + row, 0.f);
    std::fill(o, o + row, 0.f);
    const int y = r - pt;
    if (y < 0 || y >= h) continue;
    const float* s = src + std::size_t(y) * w;
    if (pl % 2 == 0)
      split_even_odd_columns(s, w, e + pl / 2, o + pl / 2);
    else  // src's even columns fall on odd bordered ones
      split_even_odd_columns(s, w, o + pl / 2, e + (pl + 1) / 2);
  }
}

#endif

}  // namespace

bool depthwise_avx2_supported() {
#ifdef KEYFLEET_DEPTHWISE_X86
  static const bool supported =
      cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
  return supported;
#else
  return false;
#endif
}

#ifdef KEYFLEET_DEPTHWISE_X86
__attribute__((target("avx2,fma"))) void split_even_odd_columns(const float* src, int n,
                                                                float* even, float* odd) {
  int j = 0;
  for (; 2 * j + 16 <= n; j += 8) {
    const __m256 a = _mm256_loadu_ps(src + 2 * j), b = _mm256_loadu_ps(src + 2 * j + 8);
    // Per lane (a0 a2 b0 b2 | a4 a6 b4 b6), then the middle pairs swapped across lanes.
    const __m256 e = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0));
    const __m256 o = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
    _mm256_storeu_ps(even + j, _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(e), 0xD8)));
    _mm256_storeu_ps(odd + j, _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(o), 0xD8)));
  }
  for (; 2 * j < n; ++j) {
    even[j] = src[2 * j];
    if (2 * j + 1 < n) odd[j] = src[2 * j + 1];
  }
}
#else
void split_even_odd_columns(const float* src, int n, float* even, float* odd) {
  for (int j = 0; 2 * j < n; ++j) {
    even[j] = src[2 * j];
    if (2 * j + 1 < n) odd[j] = src[2 * j + 1];
  }
}
#endif

#ifdef KEYFLEET_DEPTHWISE_X86
__attribute__((target("avx2,fma")))
#endif
void depthwise_plane_avx2(const float* src, int h, int w, const float* kernel, int kh, int kw,
                          int dh, int dw, int pt, int pl, int sh, int sw, float bias, float* dst,
                          int ho, int wo) {
#ifdef KEYFLEET_DEPTHWISE_X86
  // Output (y, x) reads bordered (y sh + ky dh, x sw + kx dw): rows up to (ho - 1) sh + (kh - 1)
  // dh, columns up to the last vector's end times sw plus (kw - 1) dw; the input needs at least
  // h + pt rows and w + pl columns of it.
  const int vector_columns = (wo + 7) / 8 * 8;
  const int height = std::max((ho - 1) * sh + (kh - 1) * dh + 1, h + pt);
  // The bordered plane; a plane of the geometry of the one before finds its zero border still
  // there and copies its rows alone (a layer's planes come one after another: on PP-OCR's
  // recogniser's 40-column planes the border took a quarter of the time).
  thread_local ZeroBorderedRows bordered;
  thread_local std::vector<float> phases;
  const float* plane = nullptr;
  int row = 0;  // floats between rows of `plane`
  if (sw == 1) {
    row = std::max(vector_columns + (kw - 1) * dw, w + pl);
    plane = bordered.fill(src, h, w, pt, pl, height, row);
  } else {
    // With stride 2 along rows the even and odd columns of the bordered plane are two planes of
    // half its width, so that each tap reads consecutive columns of one of them (tap column kx
    // dw: the even plane's from kx dw / 2 on, or the odd plane's).
    row = std::max(vector_columns + ((kw - 1) * dw + 1) / 2, (w + pl) / 2 + 1) + 1;
    phases.resize(2 * std::size_t(height) * row);
    bordered_phases(src, h, w, pt, pl, height, row, phases.data());
    plane = phases.data();
  }
  const std::size_t odd_plane = std::size_t(height) * row;
  // Kernels of 3 or 5 rows without dilation (PP-OCR's): each input vector loaded once for the
  // output rows it feeds (reused_rows), where the taps are all there (a zero tap would cost a
  // product the tap list skips).
  const bool dense = std::none_of(kernel, kernel + kh * kw, [](float k) { return k == 0.f; });
  if (dense && dh == 1 && dw == 1 && (kh == 3 || kh == 5) && kw <= 8 && (sh == 1 || sh == 2)) {
    int column_offsets[8];
    for (int kx = 0; kx < kw; ++kx)
      column_offsets[kx] = sw == 2 ? int((kx % 2) * odd_plane) + kx / 2 : kx;
    const auto run = kh == 3 ? (sh == 2 ? reused_plane<3, 2> : reused_plane<3, 1>)
                             : (sh == 2 ? reused_plane<5, 2> : reused_plane<5, 1>);
    run(kernel, kw, column_offsets, plane, std::size_t(row), bias, dst, ho, wo);
    return;
  }
  thread_local std::vector<Tap> taps;
  taps.clear();
  for (int ky = 0; ky < kh; ++ky)
    for (int kx = 0; kx < kw; ++kx) {
      if (kernel[ky * kw + kx] == 0.f) continue;
      const int column = kx * dw;
      const int offset = sw == 2 ? int((column % 2) * odd_plane) + column / 2 : column;
      taps.push_back({ky * dh * row + offset, kernel[ky * kw + kx]});
    }
  const std::size_t in_row = std::size_t(sh) * row;
  const int tap_count = int(taps.size());
  int y = 0;
  for (; y + 2 <= ho; y += 2)
    output_rows<2>(taps.data(), tap_count, plane + y * in_row, in_row, bias,
                   dst + std::size_t(y) * wo, std::size_t(wo), wo);
  if (y < ho)
    output_rows<1>(taps.data(), tap_count, plane + y * in_row, in_row, bias,
                   dst + std::size_t(y) * wo, std::size_t(wo), wo);
#else
  (void)src, (void)h, (void)w, (void)kernel, (void)kh, (void)kw, (void)dh, (void)dw, (void)pt;
  (void)pl, (void)sh, (void)sw, (void)bias, (void)dst, (void)ho, (void)wo;
#endif
}

}  // namespace keyfleet::vision
