// The KLT trigger's tracker (KeyframeTracker): its AVX2 path against cv::calcOpticalFlowPyrLK
// (its own fallback) on a textured image moved by a known warp, corners that leave the image
// and windows without texture lost by both, a subset of corners tracked as in the whole set,
// the window sizes the AVX2 path takes, and bad parameters refused.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "keyfleet/agent/klt_trigger.hpp"
#include "keyfleet/agent/lucas_kanade.hpp"

namespace keyfleet::agent {
namespace {

// Blurred noise: corners everywhere, smooth enough for Lucas-Kanade's linearisation.
cv::Mat texture(int width, int height, std::uint64_t seed) {
  cv::Mat noise(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 1.6);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  return smooth;
}

cv::Mat rotate_shift(double degrees, cv::Point2f shift, cv::Point2f centre) {
  cv::Mat m = cv::getRotationMatrix2D(centre, degrees, 1.0);
  m.at<double>(0, 2) += shift.x;
  m.at<double>(1, 2) += shift.y;
  cv::Mat out;
  m.convertTo(out, CV_32F);
  return out;
}

cv::Point2f apply(const cv::Mat& m, cv::Point2f p) {
  return {m.at<float>(0, 0) * p.x + m.at<float>(0, 1) * p.y + m.at<float>(0, 2),
          m.at<float>(1, 0) * p.x + m.at<float>(1, 1) * p.y + m.at<float>(1, 2)};
}

struct Tracked {
  std::vector<cv::Point2f> points;
  std::vector<std::uint8_t> status;
  std::vector<float> error;
};

// Tracks corners ids of `reference` into `frame`, each guessed at its place moved by `guess`.
Tracked run(KeyframeTracker& tracker, const cv::Mat& reference, const cv::Mat& frame,
            const std::vector<cv::Point2f>& corners, const std::vector<int>& ids,
            cv::Point2f guess = {0, 0}) {
  tracker.set_reference(reference, corners);
  Tracked t;
  for (int id : ids) t.points.push_back(corners[std::size_t(id)] + guess);
  tracker.track(frame, ids, t.points, t.status, t.error);
  return t;
}

std::vector<int> all_ids(std::size_t n) {
  std::vector<int> ids(n);
  std::iota(ids.begin(), ids.end(), 0);
  return ids;
}

#define SKIP_WITHOUT_AVX2()                                                        \
  if (!KeyframeTracker::available())                                               \
  GTEST_SKIP() << "this CPU has no AVX2 (or is not x86-64): KeyframeTracker uses " \
                  "cv::calcOpticalFlowPyrLK itself"

// Over a window size, the AVX2 path against OpenCV's on a rotated and shifted texture: the same
// corners lost, the same positions to a hundredth of a pixel (OpenCV adds its sums in float,
// this path in exact integers), the same errors, both on the true warp.
void expect_matches_opencv(int window) {
  const cv::Mat reference = texture(320, 240, 7);
  const cv::Mat m = rotate_shift(1.5, {4.3f, -2.6f}, {160, 120});
  cv::Mat frame;
  cv::warpAffine(reference, frame, m, reference.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  const std::vector<cv::Point2f> corners = spread_corners(reference, 300, 20, 7, 8);
  ASSERT_GT(corners.size(), 200u);
  const LucasKanadeParams params{window, 3, 10, 0.03};
  KeyframeTracker vectorised(params, true), opencv(params, false);
  ASSERT_TRUE(vectorised.vectorised());
  ASSERT_FALSE(opencv.vectorised());
  const std::vector<int> ids = all_ids(corners.size());
  const Tracked v = run(vectorised, reference, frame, corners, ids);
  const Tracked o = run(opencv, reference, frame, corners, ids);
  std::size_t same_status = 0, close = 0, both = 0, on_warp = 0;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    same_status += v.status[i] == o.status[i];
    if (!v.status[i] || !o.status[i]) continue;
    ++both;
    close +=
        cv::norm(v.points[i] - o.points[i]) < 0.01 && std::abs(v.error[i] - o.error[i]) < 0.01f;
    on_warp += cv::norm(v.points[i] - apply(m, corners[i])) < 0.2;
  }
  SCOPED_TRACE("window " + std::to_string(window));
  EXPECT_GE(same_status, corners.size() * 99 / 100);
  EXPECT_GE(both, corners.size() * 9 / 10);
  EXPECT_GE(close, both * 99 / 100);
  EXPECT_GE(on_warp, both * 95 / 100);
}

TEST(KeyframeTracker, MatchesOpenCvOnAWarpedTexture) {
  SKIP_WITHOUT_AVX2();
  for (int window : {15, 11, 7, 16}) expect_matches_opencv(window);
}

TEST(KeyframeTracker, LosesCornersThatLeaveTheImageAndFlatWindows) {
  SKIP_WITHOUT_AVX2();
  // The left half textured, the right half flat; the frame moved 40 px left, guessed 38.7 px
  // left (as the trigger guesses: the last frame's motion).
  cv::Mat reference = texture(320, 240, 11);
  reference(cv::Rect(160, 0, 160, 240)).setTo(128);
  cv::Mat frame(reference.size(), CV_8UC1, cv::Scalar(128));
  reference(cv::Rect(40, 0, 280, 240)).copyTo(frame(cv::Rect(0, 0, 280, 240)));
  const std::vector<cv::Point2f> corners{{10, 120}, {20, 60}, {100, 120}, {150, 100}, {240, 120}};
  for (bool avx2 : {true, false}) {
    KeyframeTracker tracker(LucasKanadeParams{}, avx2);
    const Tracked t =
        run(tracker, reference, frame, corners, all_ids(corners.size()), {-38.7f, 0.8f});
    SCOPED_TRACE(avx2 ? "AVX2" : "OpenCV");
    EXPECT_FALSE(t.status[0]);  // now at x = -30: beyond a window's width outside
    EXPECT_TRUE(t.status[2]);
    EXPECT_NEAR(t.points[2].x, 60, 0.1);
    EXPECT_NEAR(t.points[2].y, 120, 0.1);
    EXPECT_FALSE(t.status[4]);  // a flat window: no texture to track
  }
}

// Corners on the image's edges and corners, guessed on them, just outside and far outside: the
// AVX2 rows read 17 pixels from a window's left edge, which the pyramids' borders must hold (run
// under ASan or valgrind this is the test that would see a read past them); each corner is lost
// or tracked as OpenCV's tracker has it.
TEST(KeyframeTracker, CornersAtTheEdgesAsOpenCvHasThem) {
  SKIP_WITHOUT_AVX2();
  const cv::Mat reference = texture(320, 240, 5);
  const cv::Mat m = rotate_shift(0.5, {2.2f, 1.4f}, {160, 120});
  cv::Mat frame;
  cv::warpAffine(reference, frame, m, reference.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  std::vector<cv::Point2f> corners;
  for (float x : {0.f, 0.4f, 7.f, 160.f, 312.f, 318.6f, 319.f})
    for (float y : {0.f, 0.3f, 7.f, 120.f, 232.f, 238.7f, 239.f}) corners.emplace_back(x, y);
  for (cv::Point2f guess : {cv::Point2f(0, 0), cv::Point2f(1.5f, 1.5f), cv::Point2f(-1.5f, -1.5f),
                            cv::Point2f(9, 9), cv::Point2f(-9, -9), cv::Point2f(40, -40)}) {
    KeyframeTracker vectorised(LucasKanadeParams{}, true), opencv(LucasKanadeParams{}, false);
    const std::vector<int> ids = all_ids(corners.size());
    const Tracked v = run(vectorised, reference, frame, corners, ids, guess);
    const Tracked o = run(opencv, reference, frame, corners, ids, guess);
    std::size_t same = 0;
    for (std::size_t i = 0; i < corners.size(); ++i) {
      same += v.status[i] == o.status[i];
      if (v.status[i] && o.status[i]) {
        EXPECT_LT(cv::norm(v.points[i] - o.points[i]), 0.05) << i;
      }
    }
    EXPECT_GE(same + 1, corners.size()) << guess;
  }
}

TEST(KeyframeTracker, TracksASubsetAsInTheWholeSet) {
  SKIP_WITHOUT_AVX2();
  const cv::Mat reference = texture(320, 240, 3);
  const cv::Mat m = rotate_shift(-1.0, {-3.1f, 1.7f}, {150, 130});
  cv::Mat frame;
  cv::warpAffine(reference, frame, m, reference.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  const std::vector<cv::Point2f> corners = spread_corners(reference, 200, 20, 7, 8);
  KeyframeTracker tracker(LucasKanadeParams{});
  const Tracked whole = run(tracker, reference, frame, corners, all_ids(corners.size()));
  std::vector<int> odd;
  for (int i = 1; i < int(corners.size()); i += 2) odd.push_back(i);
  Tracked part;
  for (int id : odd) part.points.push_back(corners[std::size_t(id)]);
  tracker.track(frame, odd, part.points, part.status, part.error);
  ASSERT_EQ(part.points.size(), odd.size());
  for (std::size_t k = 0; k < odd.size(); ++k) {
    const std::size_t i = std::size_t(odd[k]);
    EXPECT_EQ(part.status[k], whole.status[i]);
    EXPECT_EQ(part.points[k], whole.points[i]);
    EXPECT_EQ(part.error[k], whole.error[i]);
  }
}

TEST(KeyframeTracker, WindowsOverSixteenPixelsUseOpenCv) {
  EXPECT_FALSE(KeyframeTracker(LucasKanadeParams{17, 3, 10, 0.03}).vectorised());
  EXPECT_EQ(KeyframeTracker(LucasKanadeParams{16, 3, 10, 0.03}).vectorised(),
            KeyframeTracker::available());
}

TEST(KeyframeTracker, RefusesBadParameters) {
  EXPECT_THROW(KeyframeTracker(LucasKanadeParams{2, 3, 10, 0.03}), std::invalid_argument);
  EXPECT_THROW(KeyframeTracker(LucasKanadeParams{15, 0, 10, 0.03}), std::invalid_argument);
  EXPECT_THROW(KeyframeTracker(LucasKanadeParams{15, 3, 0, 0.03}), std::invalid_argument);
  EXPECT_THROW(KeyframeTracker(LucasKanadeParams{15, 3, 101, 0.03}), std::invalid_argument);
  EXPECT_THROW(KeyframeTracker(LucasKanadeParams{15, 3, 10, -1}), std::invalid_argument);
}

}  // namespace
}  // namespace keyfleet::agent
