#include "keyfleet/agent/lucas_kanade.hpp"

#include <opencv2/core/utility.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <stdexcept>
#include <string>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define KEYFLEET_LK_X86 1
#endif

namespace keyfleet::agent {
namespace {

// OpenCV's fixed point: bilinear weights in 14 bits, grey levels kept in 1/32 (14 - 5 bits shed
// after weighting), derivatives back to their own scale (14 bits shed), sums scaled by 2^-20.
constexpr int kWeightBits = 14;
constexpr int kGreyShift = kWeightBits - 5;
constexpr float kSumScale = 1.f / (1 << 20);
constexpr float kMinEigenvalue = 1e-4f;  // calcOpticalFlowPyrLK's default minEigThreshold
constexpr std::size_t kLanes = 16;       // a window row: one AVX2 vector of int16

struct Weights {
  int w00, w01, w10, w11;
};

// The bilinear weights of the fractional position (a, b), rounded as OpenCV rounds them.
Weights weights(float a, float b) {
  Weights w{};
  w.w00 = int(std::lrint((1.f - a) * (1.f - b) * (1 << kWeightBits)));
  w.w01 = int(std::lrint(a * (1.f - b) * (1 << kWeightBits)));
  w.w10 = int(std::lrint((1.f - a) * b * (1 << kWeightBits)));
  w.w11 = (1 << kWeightBits) - w.w00 - w.w01 - w.w10;
  return w;
}

// The level's pixel at (x, y), x and y possibly in the pyramid's border.
template <typename T>
const T* at(const cv::Mat& image, int x, int y, int channels = 1) {
  return reinterpret_cast<const T*>(image.data + std::ptrdiff_t(y) * std::ptrdiff_t(image.step)) +
         std::ptrdiff_t(x) * channels;
}

#ifdef KEYFLEET_LK_X86
__attribute__((target("avx2"))) inline int lane_sum(__m256i v) {
  __m128i s = _mm_add_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, _MM_SHUFFLE(1, 0, 3, 2)));
  s = _mm_add_epi32(s, _mm_shuffle_epi32(s, _MM_SHUFFLE(2, 3, 0, 1)));
  return _mm_cvtsi128_si32(s);
}

// The weights as madd_epi16 pairs: (w00, w01) for the top row, (w10, w11) for the bottom.
struct PairWeights {
  __m256i top, bottom;
};

__attribute__((target("avx2"))) inline PairWeights pair_weights(Weights w) {
  return {_mm256_set1_epi32(int(std::uint32_t(w.w01) << 16 | std::uint32_t(w.w00))),
          _mm256_set1_epi32(int(std::uint32_t(w.w11) << 16 | std::uint32_t(w.w10)))};
}

// p00..p11: 16 int16 each, the window's corners; returns sum(weight x value) descaled by
// `shift` (rounded), 16 int16 in order. unpacklo holds 4 values of each 128-bit half and
// unpackhi the other 4; packing them back restores the order.
__attribute__((target("avx2"))) inline __m256i bilinear(__m256i p00, __m256i p01, __m256i p10,
                                                        __m256i p11, PairWeights w, int shift) {
  const __m256i half = _mm256_set1_epi32(1 << (shift - 1));
  __m256i lo = _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpacklo_epi16(p00, p01), w.top),
                                _mm256_madd_epi16(_mm256_unpacklo_epi16(p10, p11), w.bottom));
  __m256i hi = _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpackhi_epi16(p00, p01), w.top),
                                _mm256_madd_epi16(_mm256_unpackhi_epi16(p10, p11), w.bottom));
  lo = _mm256_srai_epi32(_mm256_add_epi32(lo, half), shift);
  hi = _mm256_srai_epi32(_mm256_add_epi32(hi, half), shift);
  return _mm256_packs_epi32(lo, hi);
}

__attribute__((target("avx2"))) inline __m256i widen(const std::uint8_t* p) {  // 16 of them
  return _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}

__attribute__((target("avx2"))) inline __m256i load16(const std::int16_t* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}

// 16 grey levels (1/32) interpolated from two 8-bit rows r0 and r1 = r0 + step (17 read each).
__attribute__((target("avx2"))) inline __m256i grey_row(const std::uint8_t* r0,
                                                        const std::uint8_t* r1, PairWeights w) {
  return bilinear(widen(r0), widen(r0 + 1), widen(r1), widen(r1 + 1), w, kGreyShift);
}

__attribute__((target("avx2"))) inline __m256i first_lanes(int width) {  // 0xffff below width
  const __m256i lane = _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  return _mm256_cmpgt_epi16(_mm256_set1_epi16(short(width)), lane);
}

// One pass over a window of the frame at (its top-left) `j`: each row, 16 pixels, is
// interpolated with the weights w (in 1/32 grey levels, as the reference's), then differenced
// from the reference window's grey levels `grey`. kError: returns the sum of |difference| over
// the first `width` pixels of each row; otherwise the sums of difference x derivative into
// b1 (x) and b2 (y) (the derivative planes are 0 beyond `width`, so those lanes add nothing).
// A lane adds two products a row, each under 2^25 (differences under 2^13, Scharr derivatives
// under 2^12): 16 rows stay under 2^30.
template <bool kError>
__attribute__((target("avx2"))) void window_pass(const std::uint8_t* j, std::ptrdiff_t step,
                                                 int rows, int width, Weights w,
                                                 const std::int16_t* grey, const std::int16_t* dx,
                                                 const std::int16_t* dy, int& b1, int& b2) {
  const PairWeights pw = pair_weights(w);
  const __m256i keep = _mm256_and_si256(first_lanes(width), _mm256_set1_epi16(1));
  __m256i sum1 = _mm256_setzero_si256(), sum2 = _mm256_setzero_si256();
  for (int y = 0; y < rows; ++y) {
    const std::uint8_t* r0 = j + std::ptrdiff_t(y) * step;
    const std::size_t row = std::size_t(y) * kLanes;
    const __m256i diff = _mm256_subs_epi16(grey_row(r0, r0 + step, pw), load16(grey + row));
    if constexpr (kError) {
      sum1 = _mm256_add_epi32(sum1, _mm256_madd_epi16(_mm256_abs_epi16(diff), keep));
    } else {
      sum1 = _mm256_add_epi32(sum1, _mm256_madd_epi16(diff, load16(dx + row)));
      sum2 = _mm256_add_epi32(sum2, _mm256_madd_epi16(diff, load16(dy + row)));
    }
  }
  b1 = lane_sum(sum1);
  b2 = kError ? 0 : lane_sum(sum2);
}

// 8 pixels' derivatives (x, y pairs from rows d0 and d1) interpolated, as [8 x | 8 y].
__attribute__((target("avx2"))) inline __m256i derivative_pairs(const std::int16_t* d0,
                                                                const std::int16_t* d1,
                                                                PairWeights w, __m256i split) {
  const __m256i v =
      bilinear(load16(d0), load16(d0 + 2), load16(d1), load16(d1 + 2), w, kWeightBits);
  return _mm256_permute4x64_epi64(_mm256_shuffle_epi8(v, split), _MM_SHUFFLE(3, 1, 2, 0));
}

// A reference window at `image` / `deriv` (CV_16SC2) position (x0, y0), `rows` rows of 16
// pixels: its grey levels and derivatives (0 beyond `width`) into the three planes, and the
// sums of dx dx, dx dy and dy dy over it (each lane two products a row under 2^24).
__attribute__((target("avx2"))) void reference_window(const cv::Mat& image, const cv::Mat& deriv,
                                                      int x0, int y0, int rows, int width,
                                                      Weights w, std::int16_t* grey,
                                                      std::int16_t* dx, std::int16_t* dy,
                                                      std::int64_t sums[3]) {
  const PairWeights pw = pair_weights(w);
  const __m256i keep = first_lanes(width);
  // Within each 128-bit half: x0 x1 x2 x3 y0 y1 y2 y3 from x0 y0 x1 y1 x2 y2 x3 y3.
  const __m256i split = _mm256_setr_epi8(0, 1, 4, 5, 8, 9, 12, 13, 2, 3, 6, 7, 10, 11, 14, 15, 0, 1,
                                         4, 5, 8, 9, 12, 13, 2, 3, 6, 7, 10, 11, 14, 15);
  __m256i s11 = _mm256_setzero_si256(), s12 = s11, s22 = s11;
  for (int y = 0; y < rows; ++y) {
    const std::size_t row = std::size_t(y) * kLanes;
    _mm256_storeu_si256(
        (__m256i*)(grey + row),
        grey_row(at<std::uint8_t>(image, x0, y0 + y), at<std::uint8_t>(image, x0, y0 + y + 1), pw));
    const std::int16_t* d0 = at<std::int16_t>(deriv, x0, y0 + y, 2);
    const std::int16_t* d1 = at<std::int16_t>(deriv, x0, y0 + y + 1, 2);
    const __m256i first = derivative_pairs(d0, d1, pw, split);
    const __m256i second = derivative_pairs(d0 + 16, d1 + 16, pw, split);
    const __m256i gx = _mm256_and_si256(_mm256_permute2x128_si256(first, second, 0x20), keep);
    const __m256i gy = _mm256_and_si256(_mm256_permute2x128_si256(first, second, 0x31), keep);
    _mm256_storeu_si256((__m256i*)(dx + row), gx);
    _mm256_storeu_si256((__m256i*)(dy + row), gy);
    s11 = _mm256_add_epi32(s11, _mm256_madd_epi16(gx, gx));
    s12 = _mm256_add_epi32(s12, _mm256_madd_epi16(gx, gy));
    s22 = _mm256_add_epi32(s22, _mm256_madd_epi16(gy, gy));
  }
  sums[0] = lane_sum(s11);
  sums[1] = lane_sum(s12);
  sums[2] = lane_sum(s22);
}
#endif

}  // namespace

KeyframeTracker::KeyframeTracker(const LucasKanadeParams& params, bool vectorised)
    : params_(params), vectorised_(vectorised && available() && params.window_px <= int(kLanes)) {
  if (params_.window_px < 3)
    throw std::invalid_argument("Lucas-Kanade window_px must be at least 3, got " +
                                std::to_string(params_.window_px));
  if (params_.levels < 1)
    throw std::invalid_argument("Lucas-Kanade levels must be at least 1, got " +
                                std::to_string(params_.levels));
  if (params_.iterations < 1 || params_.iterations > 100)
    throw std::invalid_argument("Lucas-Kanade iterations must be in 1..100, got " +
                                std::to_string(params_.iterations));
  if (!(params_.epsilon >= 0 && params_.epsilon <= 10))
    throw std::invalid_argument("Lucas-Kanade epsilon must be in 0..10, got " +
                                std::to_string(params_.epsilon));
}

bool KeyframeTracker::available() {
#ifdef KEYFLEET_LK_X86
  static const bool supported = cv::checkHardwareSupport(CV_CPU_AVX2);
  return supported;
#else
  return false;
#endif
}

cv::Size KeyframeTracker::border() const {
  // The AVX2 rows read 17 pixels from a window's left edge, which may be the image's last
  // column: both pyramids then get a border that wide.
  const int side = vectorised_ ? int(kLanes) + 1 : params_.window_px;
  return {side, side};
}

void KeyframeTracker::set_reference(const cv::Mat& grey, const std::vector<cv::Point2f>& corners) {
  CV_Assert(grey.type() == CV_8UC1);
  cv::buildOpticalFlowPyramid(grey, reference_, border(), params_.levels - 1, true);
  corners_ = corners;
  if (vectorised_) make_windows(corners);
}

void KeyframeTracker::make_windows(const std::vector<cv::Point2f>& corners) {
#ifdef KEYFLEET_LK_X86
  const int w = params_.window_px;
  const float half = float(w - 1) * 0.5f;
  const std::size_t plane = std::size_t(w) * kLanes;
  const std::size_t levels = reference_.size() / 2;
  levels_.assign(levels, std::vector<Window>(corners.size()));
  windows_.assign(levels * corners.size() * 3 * plane, 0);
  for (std::size_t level = 0; level < levels; ++level) {
    const cv::Mat& image = reference_[2 * level];
    const cv::Mat& deriv = reference_[2 * level + 1];  // CV_16SC2: x, y
    const float scale = float(1. / (1 << level));
    for (std::size_t k = 0; k < corners.size(); ++k) {
      Window& win = levels_[level][k];
      win.offset = (level * corners.size() + k) * 3 * plane;
      const cv::Point2f p = corners[k] * scale - cv::Point2f(half, half);
      const int x0 = int(std::floor(p.x)), y0 = int(std::floor(p.y));
      if (x0 < -w || x0 >= deriv.cols || y0 < -w || y0 >= deriv.rows) continue;
      win.inside = true;
      const Weights iw = weights(p.x - float(x0), p.y - float(y0));
      std::int16_t* grey = windows_.data() + win.offset;
      std::int16_t* dx = grey + plane;
      std::int16_t* dy = dx + plane;
      std::int64_t sums[3];  // dx dx, dx dy, dy dy
      reference_window(image, deriv, x0, y0, w, w, iw, grey, dx, dy, sums);
      win.a11 = float(sums[0]) * kSumScale;
      win.a12 = float(sums[1]) * kSumScale;
      win.a22 = float(sums[2]) * kSumScale;
      const float det = win.a11 * win.a22 - win.a12 * win.a12;
      const float min_eigenvalue =
          (win.a22 + win.a11 -
           std::sqrt((win.a11 - win.a22) * (win.a11 - win.a22) + 4.f * win.a12 * win.a12)) /
          float(2 * w * w);
      win.conditioned = !(min_eigenvalue < kMinEigenvalue || det < FLT_EPSILON);
      if (win.conditioned) win.inverse_det = 1.f / det;
    }
  }
#else
  (void)corners;
#endif
}

void KeyframeTracker::track(const cv::Mat& grey, const std::vector<int>& ids,
                            std::vector<cv::Point2f>& tracked, std::vector<std::uint8_t>& status,
                            std::vector<float>& error) {
  CV_Assert(grey.type() == CV_8UC1 && !reference_.empty());
  CV_Assert(tracked.size() == ids.size());
  if (ids.empty()) {
    status.clear();
    error.clear();
    return;
  }
  const int w = params_.window_px;
  const int frame_top =
      cv::buildOpticalFlowPyramid(grey, frame_, border(), params_.levels - 1, false);
  const int max_level = std::min(frame_top, int(reference_.size() / 2) - 1);
  if (!vectorised_) {
    gathered_.resize(ids.size());
    for (std::size_t i = 0; i < ids.size(); ++i) gathered_[i] = corners_.at(std::size_t(ids[i]));
    cv::calcOpticalFlowPyrLK(reference_, frame_, gathered_, tracked, status, error, cv::Size(w, w),
                             max_level,
                             cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                              params_.iterations, params_.epsilon),
                             cv::OPTFLOW_USE_INITIAL_FLOW);
    return;
  }
  for (int id : ids) CV_Assert(id >= 0 && std::size_t(id) < corners_.size());
  track_vectorised(max_level, ids, tracked, status, error);
}

void KeyframeTracker::track_vectorised(int max_level, const std::vector<int>& ids,
                                       std::vector<cv::Point2f>& tracked,
                                       std::vector<std::uint8_t>& status,
                                       std::vector<float>& error) const {
  status.assign(ids.size(), 1);
  error.assign(ids.size(), 0.f);
  for (int level = max_level; level >= 0; --level) {
    const float scale = float(1. / (1 << level));
    for (std::size_t i = 0; i < ids.size(); ++i) {
      // The start of this level: the guess scaled down to the coarsest, else the finer level's
      // position of the level above.
      tracked[i] = level == max_level ? tracked[i] * scale : tracked[i] * 2.f;
      const Window& window = levels_[std::size_t(level)][std::size_t(ids[i])];
      if (!window.inside || !window.conditioned) {
        if (level == 0) status[i] = 0;
        continue;
      }
      track_point(level, window, frame_[std::size_t(level)], tracked[i], status[i], error[i]);
    }
  }
}

void KeyframeTracker::track_point(int level, const Window& window, const cv::Mat& frame,
                                  cv::Point2f& point, std::uint8_t& status, float& error) const {
#ifdef KEYFLEET_LK_X86
  const int w = params_.window_px;
  const float half = float(w - 1) * 0.5f;
  const std::size_t plane = std::size_t(w) * kLanes;
  const std::int16_t* grey = windows_.data() + window.offset;
  const std::int16_t* dx = grey + plane;
  const std::int16_t* dy = dx + plane;
  const double epsilon2 = params_.epsilon * params_.epsilon;
  const std::ptrdiff_t step = std::ptrdiff_t(frame.step);
  auto outside = [&](int x0, int y0) {
    return x0 < -w || x0 >= frame.cols || y0 < -w || y0 >= frame.rows;
  };
  cv::Point2f next = point - cv::Point2f(half, half);
  cv::Point2f previous_delta;
  for (int j = 0; j < params_.iterations; ++j) {
    const int x0 = int(std::floor(next.x)), y0 = int(std::floor(next.y));
    if (outside(x0, y0)) {
      if (level == 0) status = 0;
      break;
    }
    int b1 = 0, b2 = 0;
    window_pass<false>(at<std::uint8_t>(frame, x0, y0), step, w, w,
                       weights(next.x - float(x0), next.y - float(y0)), grey, dx, dy, b1, b2);
    const float f1 = float(b1) * kSumScale, f2 = float(b2) * kSumScale;
    const cv::Point2f delta((window.a12 * f2 - window.a22 * f1) * window.inverse_det,
                            (window.a12 * f1 - window.a11 * f2) * window.inverse_det);
    next += delta;
    point = next + cv::Point2f(half, half);
    if (delta.ddot(delta) <= epsilon2) break;
    if (j > 0 && std::abs(delta.x + previous_delta.x) < 0.01f &&
        std::abs(delta.y + previous_delta.y) < 0.01f) {  // oscillating: settle between the two
      point -= delta * 0.5f;
      break;
    }
    previous_delta = delta;
  }
  if (level != 0 || !status) return;
  const cv::Point2f last = point - cv::Point2f(half, half);
  const int x0 = int(std::floor(last.x)), y0 = int(std::floor(last.y));
  if (outside(x0, y0)) {
    status = 0;
    return;
  }
  int sum = 0, unused = 0;
  window_pass<true>(at<std::uint8_t>(frame, x0, y0), step, w, w,
                    weights(last.x - float(x0), last.y - float(y0)), grey, dx, dy, sum, unused);
  error = float(sum) * (1.f / float(32 * w * w));
#else
  (void)level, (void)window, (void)frame, (void)point, (void)status, (void)error;
#endif
}

}  // namespace keyfleet::agent
