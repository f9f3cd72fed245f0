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

// Output columns [x, x + 8 * kVectors) of the row whose taps start at `in`; the last vector
// stores only `last_lanes` of its columns (8: all).
template <int kVectors>
__attribute__((target("avx2,fma"))) inline void vectors(const std::vector<Tap>& taps,
                                                        const float* in, float bias, float* out,
                                                        int last_lanes) {
  __m256 sum[kVectors];
  for (int v = 0; v < kVectors; ++v) sum[v] = _mm256_set1_ps(bias);
  for (const Tap& tap : taps) {
    const __m256 weight = _mm256_set1_ps(tap.weight);
    const float* s = in + tap.offset;
    for (int v = 0; v < kVectors; ++v)
      sum[v] = _mm256_fmadd_ps(weight, _mm256_loadu_ps(s + 8 * v), sum[v]);
  }
  for (int v = 0; v + 1 < kVectors; ++v) _mm256_storeu_ps(out + 8 * v, sum[v]);
  if (last_lanes == 8) {
    _mm256_storeu_ps(out + 8 * (kVectors - 1), sum[kVectors - 1]);
    return;
  }
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(last_lanes), lanes);
  _mm256_maskstore_ps(out + 8 * (kVectors - 1), mask, sum[kVectors - 1]);
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
__attribute__((target("avx2,fma")))
#endif
void depthwise_plane_avx2(const float* src, int h, int w, const float* kernel, int kh, int kw,
                          int dh, int dw, int pt, int pl, int sh, float bias, float* dst, int ho,
                          int wo) {
#ifdef KEYFLEET_DEPTHWISE_X86
  // Output (y, x) reads bordered (y sh + ky dh, x + kx dw): rows up to (ho - 1) sh + (kh - 1) dh,
  // columns
  // up to the last vector's end plus (kw - 1) dw; the input needs at least h + pt rows and
  // w + pl columns of it.
  const int vector_columns = (wo + 7) / 8 * 8;
  const int width = std::max(vector_columns + (kw - 1) * dw, w + pl);
  const int height = std::max((ho - 1) * sh + (kh - 1) * dh + 1, h + pt);
  thread_local std::vector<float> bordered;
  bordered.resize(std::size_t(height) * width);
  copy_with_zero_border(src, h, w, pt, pl, height, width, bordered.data());
  std::vector<Tap> taps;
  taps.reserve(std::size_t(kh) * kw);
  for (int ky = 0; ky < kh; ++ky)
    for (int kx = 0; kx < kw; ++kx)
      if (kernel[ky * kw + kx] != 0.f)
        taps.push_back({ky * dh * width + kx * dw, kernel[ky * kw + kx]});
  for (int y = 0; y < ho; ++y) {
    const float* in = bordered.data() + std::size_t(y) * sh * width;
    float* out = dst + std::size_t(y) * wo;
    int x = 0;
    for (; x + 32 <= wo; x += 32) vectors<4>(taps, in + x, bias, out + x, 8);
    for (; x < wo; x += 8) vectors<1>(taps, in + x, bias, out + x, std::min(8, wo - x));
  }
#else
  (void)src, (void)h, (void)w, (void)kernel, (void)kh, (void)kw, (void)dh, (void)dw, (void)pt;
  (void)pl, (void)sh, (void)bias, (void)dst, (void)ho, (void)wo;
#endif
}

}  // namespace keyfleet::vision
