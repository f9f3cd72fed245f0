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
  thread_local std::vector<float> bordered;
  int row = 0;  // floats between rows of `plane`
  if (sw == 1) {
    row = std::max(vector_columns + (kw - 1) * dw, w + pl);
    bordered.resize(std::size_t(height) * row);
    copy_with_zero_border(src, h, w, pt, pl, height, row, bordered.data());
  } else {
    // With stride 2 along rows the even and odd columns of the bordered plane are two planes of
    // half its width, so that each tap reads consecutive columns of one of them (tap column kx
    // dw: the even plane's from kx dw / 2 on, or the odd plane's).
    row = std::max(vector_columns + ((kw - 1) * dw + 1) / 2, (w + pl) / 2 + 1) + 1;
    bordered.resize(2 * std::size_t(height) * row);
    bordered_phases(src, h, w, pt, pl, height, row, bordered.data());
  }
  const float* plane = bordered.data();
  const std::size_t odd_plane = std::size_t(height) * row;
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
