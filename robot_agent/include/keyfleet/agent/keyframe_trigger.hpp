#pragma once
// Which frames a V-SLAM system would take as keyframes: the anchors of the selection.
#include <memory>
#include <string>
#include <vector>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/grid_orb_extractor.hpp"
#include "keyfleet/agent/need_new_keyframe.hpp"

namespace keyfleet::agent {

class KeyframeTrigger {
 public:
  virtual ~KeyframeTrigger() = default;
  virtual bool is_keyframe(const Frame& frame) = 0;
  // The same decision, given the frame already in grey at some size (the quality stage's): a
  // trigger that works at that size takes it instead of making its own.
  virtual bool is_keyframe_given_grey(const Frame& frame, const cv::Mat& grey) {
    (void)grey;
    return is_keyframe(frame);
  }
};

class StrideTrigger final : public KeyframeTrigger {
 public:
  explicit StrideTrigger(int stride) : stride_(std::uint64_t(std::max(1, stride))) {}
  bool is_keyframe(const Frame& frame) override { return frame.index % stride_ == 0; }

 private:
  std::uint64_t stride_;
};

// Keyframes from an ORB-SLAM2/3 KeyFrameTrajectory.txt (TUM: timestamp tx ty tz qx qy qz qw,
// seconds): a frame is a keyframe when a listed timestamp falls within half a frame period
// of its capture time.
class ListTrigger final : public KeyframeTrigger {
 public:
  // Throws StartupError naming the file and line that cannot be read.
  ListTrigger(const std::string& path, double fps);
  bool is_keyframe(const Frame& frame) override;
  std::size_t listed() const { return times_ns_.size(); }

 private:
  std::vector<std::int64_t> times_ns_;
  std::int64_t tolerance_ns_;
};

// The size a trigger tracks at: the frame's own size (not a reduced decode's, see
// Frame::full_size) times image_scale, each side at least 1.
cv::Size tracking_size(const Frame& frame, double image_scale);

struct OrbSlamTriggerParams {
  GridOrbParams orb;
  NeedNewKeyframeParams decision;
  double image_scale = 0.5;      // frames are resized by this before feature extraction
  double ransac_px = 1.0;        // epipolar distance threshold, pixels of the resized image
  double search_radius_px = 24;  // guided matching radius at full resolution
  int max_hamming = 50;          // ORB-SLAM2 TH_LOW
  double nn_ratio = 0.9;
};

// Emulates ORB-SLAM2's monocular Tracking::NeedNewKeyFrame (need_new_keyframe.hpp) on ORB
// features tracked against the reference (last) keyframe. Matching is guided as ORB-SLAM2's
// is: each reference feature is searched for within a radius around where a constant-velocity
// model puts it (the image shift of the previous frame), at a neighbouring scale, best Hamming
// distance under max_hamming and nn_ratio times the second best. inliers = matches consistent
// with a fundamental matrix (RANSAC).
class OrbSlamTrigger final : public KeyframeTrigger {
 public:
  explicit OrbSlamTrigger(const OrbSlamTriggerParams& params);
  bool is_keyframe(const Frame& frame) override;

  int last_inliers() const { return last_inliers_; }
  int reference_tracked() const { return decision_.reference_tracked(); }

 private:
  int track(const OrbFeatures& current);  // inliers against the reference keyframe

  OrbSlamTriggerParams params_;
  GridOrbExtractor extractor_;
  NeedNewKeyframe decision_;
  OrbFeatures reference_;
  int last_inliers_ = 0;
  cv::Point2f shift_{0, 0};  // image motion of the reference features in the last frame
};

}  // namespace keyfleet::agent
