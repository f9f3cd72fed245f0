#include "selu_avx2.hpp"

#include <opencv2/core/utility.hpp>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define KEYFLEET_SELU_X86 1
#endif

namespace keyfleet::vision {

#ifdef KEYFLEET_SELU_X86
namespace {

// exp(x) for x <= 0: x = n ln2 + r with |r| <= ln2 / 2 (ln2 in two parts, so r is exact to
// float rounding), exp(r) by its Taylor series to r^7 / 7! (the next term is below 4e-9 of
// the sum), times 2^n built in the exponent bits. Inputs below -87 give exp(-87) (~1.6e-38):
// SELU subtracts 1 from it.
__attribute__((target("avx2,fma"))) __m256 exp_nonpositive(__m256 x) {
  x = _mm256_max_ps(x, _mm256_set1_ps(-87.f));
  const __m256 n = _mm256_round_ps(_mm256_mul_ps(x, _mm256_set1_ps(1.44269504088896341f)),
                                   _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m256 r = _mm256_fnmadd_ps(n, _mm256_set1_ps(0.693145751953125f), x);
  r = _mm256_fnmadd_ps(n, _mm256_set1_ps(1.428606765330187045e-6f), r);
  const float inverse_factorials[] = {1.f / 5040, 1.f / 720, 1.f / 120, 1.f / 24,
                                      1.f / 6,    1.f / 2,   1.f,       1.f};
  __m256 p = _mm256_set1_ps(inverse_factorials[0]);
  for (int i = 1; i < 8; ++i) p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(inverse_factorials[i]));
  const __m256i bits =
      _mm256_slli_epi32(_mm256_add_epi32(_mm256_cvtps_epi32(n), _mm256_set1_epi32(127)), 23);
  return _mm256_mul_ps(p, _mm256_castsi256_ps(bits));
}

__attribute__((target("avx2,fma"))) void selu_vectors(const float* src, float* dst, int n,
                                                      float alpha, float gamma) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.f);
  const __m256 a = _mm256_set1_ps(alpha), g = _mm256_set1_ps(gamma);
  for (int i = 0; i < n; i += 8) {
    const __m256 x = _mm256_loadu_ps(src + i);
    const __m256 negative =
        _mm256_mul_ps(a, _mm256_sub_ps(exp_nonpositive(_mm256_min_ps(x, zero)), one));
    _mm256_storeu_ps(dst + i, _mm256_mul_ps(g, _mm256_add_ps(_mm256_max_ps(x, zero), negative)));
  }
}

}  // namespace
#endif

int selu_avx2(const float* src, float* dst, int n, float alpha, float gamma) {
#ifdef KEYFLEET_SELU_X86
  static const bool supported =
      cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
  if (!supported) return 0;
  const int whole = n / 8 * 8;
  selu_vectors(src, dst, whole, alpha, gamma);
  return whole;
#else
  (void)src, (void)dst, (void)n, (void)alpha, (void)gamma;
  return 0;
#endif
}

}  // namespace keyfleet::vision
