#pragma once
// Pyramidal Lucas-Kanade tracking of one keyframe's corners into the frames after it: the KLT
// trigger's tracker (klt_trigger.hpp).
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace keyfleet::agent {

struct LucasKanadeParams {
  int window_px = 15;     // window side (odd or even; at least 3)
  int levels = 3;         // pyramid levels (1 = no pyramid)
  int iterations = 10;    // Gauss-Newton steps per level at most (1..100)
  double epsilon = 0.03;  // a step shorter than this (pixels of its level) ends a level
};

// The arithmetic of OpenCV's cv::calcOpticalFlowPyrLK (windows interpolated bilinearly in 14-bit
// fixed point, grey levels in 1/32, Scharr derivatives, its minimum-eigenvalue test at 1e-4, its
// two stopping rules and its error: the mean absolute difference of the final window), with two
// differences in how it is done where the CPU has AVX2 (x86-64):
// - each corner's reference windows (grey levels, derivatives, the 2x2 normal matrix), which
//   depend on the keyframe only, are made once in set_reference, not again for every frame;
// - a window row of up to 16 pixels is one AVX2 vector (OpenCV 4.6 takes 8 pixels a step in SSE
//   and a 15-pixel row's other 7 one by one), its sums exact 32-bit integers where OpenCV adds
//   floats, so a tracked position may differ from OpenCV's in its last bits.
// Elsewhere (without AVX2, windows over 16 pixels, or vectorised = false) track() calls
// cv::calcOpticalFlowPyrLK itself.
class KeyframeTracker {
 public:
  explicit KeyframeTracker(const LucasKanadeParams& params, bool vectorised = available());

  // Whether this CPU runs the AVX2 path.
  static bool available();
  bool vectorised() const { return vectorised_; }

  // The keyframe (8-bit grey) and the corners to track from it; their windows are made here.
  void set_reference(const cv::Mat& grey, const std::vector<cv::Point2f>& corners);

  // Tracks reference corners ids[i] into `grey` (a later frame of the keyframe's size):
  // tracked[i] holds a guess of where it is on entry and the tracked position on return;
  // status[i] = 0 where it was lost (left the image, or its window has no texture), error[i] the
  // mean absolute grey difference of its window (0 where lost before level 0).
  void track(const cv::Mat& grey, const std::vector<int>& ids, std::vector<cv::Point2f>& tracked,
             std::vector<std::uint8_t>& status, std::vector<float>& error);

 private:
  struct Window {            // one corner at one level of the keyframe's pyramid
    std::size_t offset = 0;  // of its planes in windows_
    float a11 = 0, a12 = 0, a22 = 0, inverse_det = 0;
    bool inside = false;       // its window lies within the level's bordered image
    bool conditioned = false;  // and has texture enough (OpenCV's minimum eigenvalue test)
  };
  cv::Size border() const;  // of both pyramids (buildOpticalFlowPyramid's winSize)
  void make_windows(const std::vector<cv::Point2f>& corners);
  void track_vectorised(int max_level, const std::vector<int>& ids,
                        std::vector<cv::Point2f>& tracked, std::vector<std::uint8_t>& status,
                        std::vector<float>& error) const;
  void track_point(int level, const Window& window, const cv::Mat& frame, cv::Point2f& point,
                   std::uint8_t& status, float& error) const;

  LucasKanadeParams params_;
  bool vectorised_;
  std::vector<cv::Mat> reference_, frame_;  // pyramids (the keyframe's with derivatives)
  std::vector<cv::Point2f> corners_;
  std::vector<std::vector<Window>> levels_;  // [level][corner]
  std::vector<std::int16_t> windows_;  // each Window's grey, x and y derivative planes, 16 a row
  std::vector<cv::Point2f> gathered_;  // corners ids (the OpenCV path)
};

}  // namespace keyfleet::agent
