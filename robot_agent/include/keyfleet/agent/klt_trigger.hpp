#pragma once
// A cheaper V-SLAM trigger: ORB-SLAM2's keyframe decision on corners tracked by optical flow.
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/agent/image_quality.hpp"
#include "keyfleet/agent/keyframe_trigger.hpp"
#include "keyfleet/agent/lucas_kanade.hpp"
#include "keyfleet/agent/need_new_keyframe.hpp"

namespace keyfleet::agent {

struct KltTriggerParams {
  // ORB-SLAM2's decision with this trigger's ratio 0.95 (KltConfig::ref_ratio says why).
  NeedNewKeyframeParams decision{30, 2, 0.95, 15, 5};
  double image_scale = 0.5;  // frames are resized by this before detection and tracking
  int max_points = 300;      // corners detected on each keyframe
  int cell_px = 20;          // spread: the strongest corners of each cell (resized image)
  int fast_threshold = 7;    // weakest FAST corner accepted (ORB-SLAM2's lowered threshold)
  int window_px = 15;        // KLT window side
  int pyramid_levels = 3;    // KLT pyramid levels (1 = no pyramid)
  int iterations = 10;       // KLT iterations per level at most
  double max_error = 30;     // mean absolute grey difference of a tracked window, at most
  int border_px = 8;         // corners detected and tracked this far inside the image only
  double ransac_px = 1.0;    // epipolar distance threshold, pixels of the resized image
};

// Emulates ORB-SLAM2's monocular Tracking::NeedNewKeyFrame (need_new_keyframe.hpp) as
// OrbSlamTrigger does, with cheaper tracking on the frame area-resized by image_scale: FAST corners
// spread over a grid are detected on each keyframe only, and every later frame tracks them from the
// reference keyframe's image by pyramidal Lucas-Kanade, starting from where a constant-velocity
// model puts them (their position in the previous frame plus the last median step). inliers =
// tracked corners consistent with a fundamental matrix (RANSAC); a corner lost or rejected once
// stays lost until the next keyframe, as a map point ORB-SLAM2 culls.
class KltSlamTrigger final : public KeyframeTrigger {
 public:
  explicit KltSlamTrigger(const KltTriggerParams& params);
  bool is_keyframe(const Frame& frame) override;
  // `grey` is used when it is the frame area-resized by image_scale, then turned grey (what
  // QualityImages::work_grey holds at the sharpness width): the same pixels the trigger makes.
  bool is_keyframe_given_grey(const Frame& frame, const cv::Mat& grey) override;

  int last_inliers() const { return last_inliers_; }
  int reference_tracked() const { return decision_.reference_tracked(); }
  std::size_t reference_corners() const { return corners_; }

 private:
  bool decide();  // on grey_
  void make_reference();
  int track();  // inliers against the reference keyframe

  KltTriggerParams params_;
  NeedNewKeyframe decision_;
  AreaResizer resizer_;
  cv::Mat resized_, own_grey_;  // the frame area-resized, then in grey (buffers reused)
  cv::Mat grey_;                // the grey image tracked: own_grey_ or the one given
  KeyframeTracker tracker_;     // holds the keyframe's pyramid and windows
  std::vector<int> ids_;        // the tracker's index of each corner still tracked
  std::vector<cv::Point2f> reference_points_;  // corners still tracked, in the keyframe
  std::vector<cv::Point2f> previous_points_;   // the same corners in the previous frame
  std::vector<cv::Point2f> tracked_;
  std::vector<std::uint8_t> status_;
  std::vector<float> error_;
  std::size_t corners_ = 0;
  int last_inliers_ = 0;
  cv::Point2f step_{0, 0};  // median image motion of the corners over the last frame
};

// FAST corners spread over the image (less a border): the strongest of each cell_px x cell_px
// cell, at most max_points in all (the strongest kept when the cells' quotas add up to more).
std::vector<cv::Point2f> spread_corners(const cv::Mat& grey, int max_points, int cell_px,
                                        int fast_threshold, int border_px = 0);

}  // namespace keyfleet::agent
