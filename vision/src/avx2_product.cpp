#include "avx2_product.hpp"

#include <opencv2/core.hpp>

#include <algorithm>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define KEYFLEET_PRODUCT_X86 1
#endif

namespace keyfleet::vision {
namespace {

#ifdef KEYFLEET_PRODUCT_X86
// rows x (vectors x 8 lanes) block of out = bias (or out) + sum over taps t and k of
// a[t][k][row] * b[k plane + shift[t] + lane]. The loop over taps is unrolled (kTaps loops one
// after the other), and so are the loops over rows and vectors (the pragmas: left to itself
// GCC stores the accumulators to the stack on every step, a third of the time).
template <int kRows, int kVectors, int kTaps>
__attribute__((target("avx2,fma"))) void tile(const float* a, std::size_t a_tap_stride,
                                              const float* b, const int* shifts, int depth,
                                              std::size_t plane, const float* bias, float* out,
                                              std::size_t out_stride, bool stream) {
  __m256 acc[kRows][kVectors];
#pragma GCC unroll 16
  for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 16
    for (int v = 0; v < kVectors; ++v)
      acc[r][v] = bias ? _mm256_set1_ps(bias[r]) : _mm256_loadu_ps(out + r * out_stride + 8 * v);
#pragma GCC unroll 4
  for (int t = 0; t < kTaps; ++t) {
    const float* at = a + t * a_tap_stride;
    const float* bt = b + shifts[t];
    for (int k = 0; k < depth; ++k, at += kRows, bt += plane) {
      __m256 bv[kVectors];
#pragma GCC unroll 16
      for (int v = 0; v < kVectors; ++v) bv[v] = _mm256_loadu_ps(bt + 8 * v);
#pragma GCC unroll 16
      for (int r = 0; r < kRows; ++r) {
        const __m256 ar = _mm256_broadcast_ss(at + r);
#pragma GCC unroll 16
        for (int v = 0; v < kVectors; ++v) acc[r][v] = _mm256_fmadd_ps(ar, bv[v], acc[r][v]);
      }
    }
  }
  if (stream && vector_aligned(out) && out_stride % 8 == 0) {
#pragma GCC unroll 16
    for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 16
      for (int v = 0; v < kVectors; ++v) _mm256_stream_ps(out + r * out_stride + 8 * v, acc[r][v]);
    return;
  }
#pragma GCC unroll 16
  for (int r = 0; r < kRows; ++r)
#pragma GCC unroll 16
    for (int v = 0; v < kVectors; ++v) _mm256_storeu_ps(out + r * out_stride + 8 * v, acc[r][v]);
}

template <int kRows, int kVectors>
void tile_for_taps(int taps, const float* a, std::size_t a_tap_stride, const float* b,
                   const int* shifts, int depth, std::size_t plane, const float* bias, float* out,
                   std::size_t out_stride, bool stream) {
  switch (taps) {
    case 1:
      tile<kRows, kVectors, 1>(a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                               stream);
      break;
    case 2:
      tile<kRows, kVectors, 2>(a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                               stream);
      break;
    case 9:
      tile<kRows, kVectors, 9>(a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                               stream);
      break;
    default:
      tile<kRows, kVectors, 4>(a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                               stream);
  }
}
#endif

}  // namespace

bool product_supported() {
#ifdef KEYFLEET_PRODUCT_X86
  return cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
#else
  return false;
#endif
}

void stores_fence() {
#ifdef KEYFLEET_PRODUCT_X86
  _mm_sfence();
#endif
}

#ifdef KEYFLEET_PRODUCT_X86
__attribute__((target("avx2"))) void stream_floats(const float* src, float* dst, int n) {
  int i = 0;
  for (; i + 8 <= n; i += 8) _mm256_stream_ps(dst + i, _mm256_loadu_ps(src + i));
  for (; i < n; ++i) dst[i] = src[i];
}
#else
void stream_floats(const float* src, float* dst, int n) { std::copy_n(src, n, dst); }
#endif

ProductBlock ProductBlock::least_padding(int rows, int columns,
                                         std::initializer_list<ProductBlock> shapes) {
  ProductBlock best = *shapes.begin();
  long least = -1;
  for (const ProductBlock block : shapes) {
    const long padded = long((rows + block.rows - 1) / block.rows * block.rows) *
                        ((columns + block.columns - 1) / block.columns * block.columns);
    if (least < 0 || padded < least) best = block, least = padded;
  }
  return best;
}

ProductBlock float_product_block(int rows, int columns) {
  return ProductBlock::least_padding(rows, columns, {{6, 16}, {4, 24}, {2, 48}});
}

void product_block(ProductBlock block, int taps, const float* a, std::size_t a_tap_stride,
                   const float* b, const int* shifts, int depth, std::size_t plane,
                   const float* bias, float* out, std::size_t out_stride, bool stream) {
#ifdef KEYFLEET_PRODUCT_X86
  switch (block.rows) {
    case 6:
      tile_for_taps<6, 2>(taps, a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                          stream);
      break;
    case 4:
      tile_for_taps<4, 3>(taps, a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                          stream);
      break;
    default:
      tile_for_taps<2, 6>(taps, a, a_tap_stride, b, shifts, depth, plane, bias, out, out_stride,
                          stream);
  }
#else
  (void)block, (void)taps, (void)a, (void)a_tap_stride, (void)b, (void)shifts, (void)depth,
      (void)plane, (void)bias, (void)out, (void)out_stride, (void)stream;
  CV_Error(cv::Error::StsNotImplemented, "keyfleet's matrix product needs x86-64 with AVX2");
#endif
}

}  // namespace keyfleet::vision
