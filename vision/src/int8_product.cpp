#include "int8_product.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#if defined(__GNUC__) && defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#define KEYFLEET_INT8_X86 1
#define KEYFLEET_INT8_TARGET __attribute__((target("avx2,fma")))
#define KEYFLEET_AVX_VNNI_TARGET __attribute__((target("avx2,fma,avxvnni")))
#define KEYFLEET_AVX512_VNNI_TARGET __attribute__((target("avx2,fma,avx512f,avx512vl,avx512vnni")))
#endif

namespace keyfleet::vision {
namespace {

#ifdef KEYFLEET_INT8_X86
// One product of a quad into 32-bit sums, three ways with the same sums: AVX2's vpmaddubsw
// (unsigned input bytes times signed weight bytes, pairs summed to 16 bits) then vpmaddwd by ones
// (pairs of those summed to 32 bits); VNNI's vpdpbusd, one instruction for both (VEX-encoded on
// AVX-VNNI CPUs, EVEX on AVX512-VNNI ones).
KEYFLEET_INT8_TARGET inline __m256i dot_avx2(__m256i acc, __m256i b, __m256i a) {
  return _mm256_add_epi32(acc, _mm256_madd_epi16(_mm256_maddubs_epi16(b, a), _mm256_set1_epi16(1)));
}
KEYFLEET_AVX_VNNI_TARGET inline __m256i dot_avx_vnni(__m256i acc, __m256i b, __m256i a) {
  return _mm256_dpbusd_avx_epi32(acc, b, a);
}
KEYFLEET_AVX512_VNNI_TARGET inline __m256i dot_avx512_vnni(__m256i acc, __m256i b, __m256i a) {
  return _mm256_dpbusd_epi32(acc, b, a);
}

// rows x (vectors x 8 lanes) block; the loops over rows and vectors unrolled so that the
// accumulators stay in registers (as in avx2_product.cpp). One function per instruction set (a
// function's target cannot depend on a template argument).
#define KEYFLEET_INT8_TILE(NAME, TARGET, DOT)                                                     \
  template <int kRows, int kVectors>                                                              \
  TARGET void NAME(const std::uint32_t* a, const std::uint32_t* b, int quads, std::size_t plane,  \
                   const float* scale, const float* offset, float* out, std::size_t out_stride) { \
    __m256i acc[kRows][kVectors];                                                                 \
    _Pragma("GCC unroll 16") for (int r = 0; r < kRows; ++r)                                      \
        _Pragma("GCC unroll 16") for (int v = 0; v < kVectors; ++v) acc[r][v] =                   \
            _mm256_setzero_si256();                                                               \
    for (int q = 0; q < quads; ++q, a += kRows, b += plane) {                                     \
      __m256i bv[kVectors];                                                                       \
      _Pragma("GCC unroll 16") for (int v = 0; v < kVectors; ++v) bv[v] =                         \
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b + 8 * v));                        \
      _Pragma("GCC unroll 16") for (int r = 0; r < kRows; ++r) {                                  \
        const __m256i ar = _mm256_set1_epi32(int(a[r]));                                          \
        _Pragma("GCC unroll 16") for (int v = 0; v < kVectors; ++v) acc[r][v] =                   \
            DOT(acc[r][v], bv[v], ar);                                                            \
      }                                                                                           \
    }                                                                                             \
    _Pragma("GCC unroll 16") for (int r = 0; r < kRows; ++r) {                                    \
      const __m256 s = _mm256_set1_ps(scale[r]);                                                  \
      _Pragma("GCC unroll 16") for (int v = 0; v < kVectors; ++v) {                               \
        float* o = out + r * out_stride + 8 * v;                                                  \
        const __m256 base = offset ? _mm256_set1_ps(offset[r]) : _mm256_loadu_ps(o);              \
        _mm256_storeu_ps(o, _mm256_fmadd_ps(s, _mm256_cvtepi32_ps(acc[r][v]), base));             \
      }                                                                                           \
    }                                                                                             \
  }

KEYFLEET_INT8_TILE(tile_avx2, KEYFLEET_INT8_TARGET, dot_avx2)
KEYFLEET_INT8_TILE(tile_avx_vnni, KEYFLEET_AVX_VNNI_TARGET, dot_avx_vnni)
KEYFLEET_INT8_TILE(tile_avx512_vnni, KEYFLEET_AVX512_VNNI_TARGET, dot_avx512_vnni)
#undef KEYFLEET_INT8_TILE

// AVX-VNNI: CPUID leaf 7, sub-leaf 1, EAX bit 4.
bool cpu_has_avx_vnni() {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  return __get_cpuid_count(7, 1, &eax, &ebx, &ecx, &edx) && (eax & (1u << 4)) != 0;
}
#endif

enum class Int8Set { kNone, kAvx2, kAvxVnni, kAvx512Vnni };

// OpenCV's view of AVX-512 (OPENCV_CPU_DISABLE turns it off to approximate an AVX2 CPU); the VEX
// form only on CPUs without AVX-512 (Intel's since Alder Lake), which the approximation on an
// AVX-512 machine then leaves alone.
#ifdef KEYFLEET_INT8_X86
bool has_avx512_vnni() {
  return cv::checkHardwareSupport(CV_CPU_AVX_512F) && cv::checkHardwareSupport(CV_CPU_AVX_512VL) &&
         cv::checkHardwareSupport(CV_CPU_AVX_512VNNI);
}

Int8Set detected_set() {
  if (has_avx512_vnni()) return Int8Set::kAvx512Vnni;
  if (cpu_has_avx_vnni() && !__builtin_cpu_supports("avx512f")) return Int8Set::kAvxVnni;
  return Int8Set::kAvx2;
}

// KEYFLEET_INT8_INSTRUCTIONS=avx2|avx-vnni|avx512-vnni picks one where the CPU has it (tests and
// benchmarks of each path); anything else, or one the CPU lacks, leaves the detected choice.
Int8Set requested_or_detected_set() {
  const char* asked = std::getenv("KEYFLEET_INT8_INSTRUCTIONS");
  const std::string name = asked ? asked : "";
  if (name == "avx2") return Int8Set::kAvx2;
  if (name == "avx-vnni" && cpu_has_avx_vnni()) return Int8Set::kAvxVnni;
  if (name == "avx512-vnni" && has_avx512_vnni()) return Int8Set::kAvx512Vnni;
  return detected_set();
}
#endif

Int8Set int8_set() {
#ifdef KEYFLEET_INT8_X86
  static const Int8Set chosen = requested_or_detected_set();
  return chosen;
#else
  return Int8Set::kNone;
#endif
}
#ifdef KEYFLEET_INT8_X86

KEYFLEET_INT8_TARGET __m256i quantized(const float* x, __m256 inverse_scale, __m256i zero) {
  const __m256i q =
      _mm256_add_epi32(_mm256_cvtps_epi32(_mm256_mul_ps(_mm256_loadu_ps(x), inverse_scale)), zero);
  return _mm256_min_epi32(_mm256_max_epi32(q, _mm256_setzero_si256()),
                          _mm256_set1_epi32(kInt8InputLevels));
}

KEYFLEET_INT8_TARGET void float_range_avx2(const float* src, std::size_t n, float* lowest,
                                           float* highest) {
  __m256 lo = _mm256_set1_ps(src[0]), hi = lo;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_loadu_ps(src + i);
    lo = _mm256_min_ps(lo, x), hi = _mm256_max_ps(hi, x);
  }
  alignas(32) float l[8], h[8];
  _mm256_store_ps(l, lo), _mm256_store_ps(h, hi);
  float mn = *std::min_element(l, l + 8), mx = *std::max_element(h, h + 8);
  for (; i < n; ++i) mn = std::min(mn, src[i]), mx = std::max(mx, src[i]);
  *lowest = mn, *highest = mx;
}

KEYFLEET_INT8_TARGET void quantize_quads_avx2(const float* src, int channels, int pixels,
                                              float inverse_scale, int zero, std::uint32_t* dst,
                                              std::size_t plane) {
  const __m256 inv = _mm256_set1_ps(inverse_scale);
  const __m256i z = _mm256_set1_epi32(zero);
  const std::uint32_t zeros = std::uint32_t(zero) * 0x01010101u;
  for (int q = 0; q * 4 < channels; ++q) {
    const float* c[4];
    for (int j = 0; j < 4; ++j)
      c[j] = 4 * q + j < channels ? src + std::size_t(4 * q + j) * pixels : nullptr;
    std::uint32_t* d = dst + std::size_t(q) * plane;
    int n = 0;
    for (; n + 8 <= pixels; n += 8) {
      __m256i quad = _mm256_setzero_si256();
      for (int j = 0; j < 4; ++j)
        quad =
            _mm256_or_si256(quad, _mm256_slli_epi32(c[j] ? quantized(c[j] + n, inv, z) : z, 8 * j));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(d + n), quad);
    }
    for (; n < pixels; ++n) {
      std::uint32_t quad = 0;
      for (int j = 0; j < 4; ++j) {
        const long v = c[j] ? std::lrint(c[j][n] * inverse_scale) + zero : zero;
        quad |= std::uint32_t(std::clamp(v, 0L, long(kInt8InputLevels))) << (8 * j);
      }
      d[n] = quad;
    }
    std::fill(d + pixels, d + plane, zeros);
  }
}
#endif

}  // namespace

const char* int8_instructions() {
  switch (int8_set()) {
    case Int8Set::kAvx512Vnni: return "AVX512-VNNI";
    case Int8Set::kAvxVnni: return "AVX-VNNI";
    case Int8Set::kAvx2: return "AVX2";
    default: return "none";
  }
}

ProductBlock int8_product_block(int rows, int columns) {
  return ProductBlock::least_padding(rows, columns, {{4, 16}, {2, 32}});
}

void float_range(const float* src, std::size_t n, float* lowest, float* highest) {
  CV_Assert(n > 0);
#ifdef KEYFLEET_INT8_X86
  float_range_avx2(src, n, lowest, highest);
#else
  const auto [lo, hi] = std::minmax_element(src, src + n);
  *lowest = *lo, *highest = *hi;
#endif
}

void quantize_quads(const float* src, int channels, int pixels, float inverse_scale, int zero,
                    std::uint32_t* dst, std::size_t plane) {
  CV_Assert(plane >= std::size_t(pixels) && zero >= 0 && zero <= kInt8InputLevels);
#ifdef KEYFLEET_INT8_X86
  quantize_quads_avx2(src, channels, pixels, inverse_scale, zero, dst, plane);
#else
  (void)src, (void)channels, (void)pixels, (void)inverse_scale, (void)dst;
  CV_Error(cv::Error::StsNotImplemented, "keyfleet's int8 product needs x86-64 with AVX2");
#endif
}

void product_block_int8(ProductBlock block, const std::uint32_t* a, const std::uint32_t* b,
                        int quads, std::size_t plane, const float* scale, const float* offset,
                        float* out, std::size_t out_stride) {
#ifdef KEYFLEET_INT8_X86
  const Int8Set set = int8_set();
  const bool wide = block.rows == 4;
  if (set == Int8Set::kAvx512Vnni) {
    if (wide)
      tile_avx512_vnni<4, 2>(a, b, quads, plane, scale, offset, out, out_stride);
    else
      tile_avx512_vnni<2, 4>(a, b, quads, plane, scale, offset, out, out_stride);
  } else if (set == Int8Set::kAvxVnni) {
    if (wide)
      tile_avx_vnni<4, 2>(a, b, quads, plane, scale, offset, out, out_stride);
    else
      tile_avx_vnni<2, 4>(a, b, quads, plane, scale, offset, out, out_stride);
  } else if (wide) {
    tile_avx2<4, 2>(a, b, quads, plane, scale, offset, out, out_stride);
  } else {
    tile_avx2<2, 4>(a, b, quads, plane, scale, offset, out, out_stride);
  }
#else
  (void)block, (void)a, (void)b, (void)quads, (void)plane, (void)scale, (void)offset, (void)out,
      (void)out_stride;
  CV_Error(cv::Error::StsNotImplemented, "keyfleet's int8 product needs x86-64 with AVX2");
#endif
}

}  // namespace keyfleet::vision
