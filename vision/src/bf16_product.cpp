#include "bf16_product.hpp"

#include <opencv2/core.hpp>

#include <cmath>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define KEYFLEET_BF16_X86 1
#define KEYFLEET_BF16_TARGET __attribute__((target("avx512f,avx512bf16,avx512vl")))
#endif

namespace keyfleet::vision {
namespace {

std::uint32_t bf16_bits(float value) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  if (std::isnan(value)) return 0x7fc0u | ((bits >> 16) & 0x8000u);
  return (bits + 0x7fffu + ((bits >> 16) & 1u)) >> 16;
}

#ifdef KEYFLEET_BF16_X86
// rows x (vectors x 16 lanes) block; the loops over taps, rows and vectors unrolled so that the
// accumulators stay in registers (as in avx2_product.cpp).
template <int kRows, int kVectors, int kTaps>
KEYFLEET_BF16_TARGET void tile(const std::uint32_t* a, std::size_t a_tap_stride,
                               const std::uint32_t* b, const int* shifts, int pairs,
                               std::size_t plane, const float* bias, float* out,
                               std::size_t out_stride) {
  __m512 acc[kRows][kVectors];
#pragma GCC unroll 16
  for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 16
    for (int v = 0; v < kVectors; ++v)
      acc[r][v] = bias ? _mm512_set1_ps(bias[r]) : _mm512_loadu_ps(out + r * out_stride + 16 * v);
#pragma GCC unroll 4
  for (int t = 0; t < kTaps; ++t) {
    const std::uint32_t* at = a + t * a_tap_stride;
    const std::uint32_t* bt = b + shifts[t];
    for (int p = 0; p < pairs; ++p, at += kRows, bt += plane) {
      __m512bh bv[kVectors];
#pragma GCC unroll 16
      for (int v = 0; v < kVectors; ++v) bv[v] = (__m512bh)_mm512_loadu_si512(bt + 16 * v);
#pragma GCC unroll 16
      for (int r = 0; r < kRows; ++r) {
        const __m512bh ar = (__m512bh)_mm512_set1_epi32(int(at[r]));
#pragma GCC unroll 16
        for (int v = 0; v < kVectors; ++v) acc[r][v] = _mm512_dpbf16_ps(acc[r][v], ar, bv[v]);
      }
    }
  }
#pragma GCC unroll 16
  for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 16
    for (int v = 0; v < kVectors; ++v) _mm512_storeu_ps(out + r * out_stride + 16 * v, acc[r][v]);
}

template <int kRows, int kVectors>
void tile_for_taps(int taps, const std::uint32_t* a, std::size_t a_tap_stride,
                   const std::uint32_t* b, const int* shifts, int pairs, std::size_t plane,
                   const float* bias, float* out, std::size_t out_stride) {
  switch (taps) {
    case 1:
      tile<kRows, kVectors, 1>(a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
      break;
    case 2:
      tile<kRows, kVectors, 2>(a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
      break;
    case 9:
      tile<kRows, kVectors, 9>(a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
      break;
    default:
      tile<kRows, kVectors, 4>(a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
  }
}

// 16 floats of each of two channels to 16 pairs (the hardware's rounding: nearest, ties even).
KEYFLEET_BF16_TARGET __m512i pairs_of(__m512 low, __m512 high) {
  const __m512i lo = _mm512_maskz_cvtepu16_epi32(0xffff, (__m256i)_mm512_cvtneps_pbh(low));
  const __m512i hi = _mm512_maskz_cvtepu16_epi32(0xffff, (__m256i)_mm512_cvtneps_pbh(high));
  return _mm512_or_si512(lo, _mm512_maskz_slli_epi32(0xffff, hi, 16));
}

KEYFLEET_BF16_TARGET void pack_rows(const float* low, const float* high, int width,
                                    std::uint32_t* dst) {
  int x = 0;
  for (; x + 16 <= width; x += 16)
    _mm512_storeu_si512(dst + x, pairs_of(_mm512_loadu_ps(low + x),
                                          high ? _mm512_loadu_ps(high + x) : _mm512_setzero_ps()));
  if (x < width) {
    const __mmask16 mask = __mmask16((1u << (width - x)) - 1);
    const __m512 l = _mm512_maskz_loadu_ps(mask, low + x);
    const __m512 h = high ? _mm512_maskz_loadu_ps(mask, high + x) : _mm512_setzero_ps();
    _mm512_mask_storeu_epi32(dst + x, mask, pairs_of(l, h));
  }
}
#endif

}  // namespace

bool bf16_product_supported() {
#ifdef KEYFLEET_BF16_X86
  static const bool supported =
      __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bf16");
  return supported;
#else
  return false;
#endif
}

bool bf16_product_pays(int outputs) { return outputs >= 8 && bf16_product_supported(); }

ProductBlock bf16_product_block(int rows, int columns) {
  return ProductBlock::least_padding(rows, columns, {{6, 64}, {8, 48}, {4, 96}, {12, 32}});
}

std::uint32_t bf16_pair(float low, float high) { return bf16_bits(low) | (bf16_bits(high) << 16); }

void pack_bf16_pairs(const float* src, int channels, int rows, int width, std::uint32_t* dst,
                     std::size_t dst_plane, int dst_row_stride) {
  const std::size_t src_plane = std::size_t(rows) * width;
  for (int c = 0; c < channels; c += 2) {
    const float* low = src + std::size_t(c) * src_plane;
    const float* high = c + 1 < channels ? low + src_plane : nullptr;
    std::uint32_t* pairs = dst + std::size_t(c / 2) * dst_plane;
    for (int y = 0; y < rows; ++y) {
      const std::size_t at = std::size_t(y) * width;
      std::uint32_t* row = pairs + std::size_t(y) * dst_row_stride;
#ifdef KEYFLEET_BF16_X86
      if (bf16_product_supported()) {
        pack_rows(low + at, high ? high + at : nullptr, width, row);
        continue;
      }
#endif
      for (int x = 0; x < width; ++x) row[x] = bf16_pair(low[at + x], high ? high[at + x] : 0.f);
    }
  }
}

void product_block_bf16(ProductBlock block, int taps, const std::uint32_t* a,
                        std::size_t a_tap_stride, const std::uint32_t* b, const int* shifts,
                        int pairs, std::size_t plane, const float* bias, float* out,
                        std::size_t out_stride) {
#ifdef KEYFLEET_BF16_X86
  switch (block.rows) {
    case 6:
      tile_for_taps<6, 4>(taps, a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
      break;
    case 8:
      tile_for_taps<8, 3>(taps, a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
      break;
    case 4:
      tile_for_taps<4, 6>(taps, a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
      break;
    default:
      tile_for_taps<12, 2>(taps, a, a_tap_stride, b, shifts, pairs, plane, bias, out, out_stride);
  }
#else
  (void)block, (void)taps, (void)a, (void)a_tap_stride, (void)b, (void)shifts, (void)pairs,
      (void)plane, (void)bias, (void)out, (void)out_stride;
  CV_Error(cv::Error::StsNotImplemented, "keyfleet's bfloat16 product needs x86-64 with AVX512");
#endif
}

}  // namespace keyfleet::vision
