#include "activation_chain.hpp"

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

namespace keyfleet::vision {

namespace {

#if defined(__GNUC__) && defined(__x86_64__)
// The two loops below in AVX2 over whole vectors of 8, where the CPU has it: the columns done.
// Each the same arithmetic, in the same order, as the 4-lane loop after it (multiplies and adds,
// no fused multiply-add): the same floats.
__attribute__((target("avx2"))) int hard_swish_scale_shift_avx2(const float* src, float* dst, int n,
                                                                float scale, float shift) {
  const __m256 zero = _mm256_setzero_ps(), three = _mm256_set1_ps(3.f), six = _mm256_set1_ps(6.f),
               a = _mm256_set1_ps(scale / 6.f), b = _mm256_set1_ps(shift);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_loadu_ps(src + i);
    const __m256 gate = _mm256_min_ps(_mm256_max_ps(_mm256_add_ps(x, three), zero), six);
    _mm256_storeu_ps(dst + i, _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(x, gate), a), b));
  }
  return i;
}

__attribute__((target("avx2"))) int scale_shift_avx2(const float* src, float* dst, int n,
                                                     float scale, float shift) {
  const __m256 a = _mm256_set1_ps(scale), b = _mm256_set1_ps(shift);
  int i = 0;
  for (; i + 8 <= n; i += 8)
    _mm256_storeu_ps(dst + i, _mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(src + i), a), b));
  return i;
}

bool has_avx2() {
  static const bool supported = cv::checkHardwareSupport(CV_CPU_AVX2);
  return supported;
}
#else
int hard_swish_scale_shift_avx2(const float*, float*, int, float, float) { return 0; }
int scale_shift_avx2(const float*, float*, int, float, float) { return 0; }
bool has_avx2() { return false; }
#endif

}  // namespace

// dst = scale * hard_swish(src) + shift in one pass, n floats (in place allowed).
void hard_swish_scale_shift_vectorised(const float* src, float* dst, int n, float scale,
                                       float shift) {
  int i = has_avx2() ? hard_swish_scale_shift_avx2(src, dst, n, scale, shift) : 0;
  const cv::v_float32 zero = cv::vx_setzero_f32(), three = cv::vx_setall_f32(3.f),
                      six = cv::vx_setall_f32(6.f), a = cv::vx_setall_f32(scale / 6.f),
                      b = cv::vx_setall_f32(shift);
  constexpr int kLanes = cv::v_float32::nlanes;
  for (; i + kLanes <= n; i += kLanes) {
    const cv::v_float32 x = cv::vx_load(src + i);
    cv::v_store(dst + i, (x * cv::v_min(cv::v_max(x + three, zero), six)) * a + b);
  }
  for (; i < n; ++i)
    dst[i] = src[i] * std::min(std::max(src[i] + 3.f, 0.f), 6.f) * (scale / 6.f) + shift;
}

// dst = scale * src + shift, n floats (in place allowed).
void scale_shift_vectorised(const float* src, float* dst, int n, float scale, float shift) {
  int i = has_avx2() ? scale_shift_avx2(src, dst, n, scale, shift) : 0;
  const cv::v_float32 a = cv::vx_setall_f32(scale), b = cv::vx_setall_f32(shift);
  constexpr int kLanes = cv::v_float32::nlanes;
  for (; i + kLanes <= n; i += kLanes) cv::v_store(dst + i, cv::vx_load(src + i) * a + b);
  for (; i < n; ++i) dst[i] = src[i] * scale + shift;
}

bool ActivationChain::add(const cv::Ptr<cv::dnn::ActivationLayer>& layer) {
  if (layer.empty()) {
    steps_.clear();
    return false;
  }
  const auto* power = dynamic_cast<const cv::dnn::PowerLayer*>(layer.get());
  if (power && power->power == 1.f) {
    Step* last = steps_.empty() ? nullptr : &steps_.back();
    if (!last || !(last->affine || is_hard_swish_stand_in(last->layer.get()))) {
      steps_.push_back({nullptr, true, power->scale, power->shift});
      return true;
    }
    // scale' (scale x + shift) + shift'
    last->shift = power->scale * (last->affine ? last->shift : 0.f) + power->shift;
    last->scale = power->scale * (last->affine ? last->scale : 1.f);
    last->affine = true;
    return true;
  }
  steps_.push_back({layer, false, 1.f, 0.f});
  return true;
}

void ActivationChain::forwardSlice(const float* src, float* dst, int len, size_t plane_size,
                                   int cn0, int cn1) const {
  for (std::size_t i = 0; i < steps_.size(); ++i) {
    const Step& step = steps_[i];
    const float* in = i == 0 ? src : dst;
    if (step.layer && !step.affine) {
      step.layer->forwardSlice(in, dst, len, plane_size, cn0, cn1);
      continue;
    }
    for (int c = cn0; c < cn1; ++c) {
      const std::size_t at = std::size_t(c - cn0) * plane_size;
      if (step.layer)  // a hard swish, then its scale and shift
        hard_swish_scale_shift_vectorised(in + at, dst + at, len, step.scale, step.shift);
      else
        scale_shift_vectorised(in + at, dst + at, len, step.scale, step.shift);
    }
  }
}

}  // namespace keyfleet::vision
