#pragma once
// Which frames a V-SLAM system would take as keyframes: the anchors of the selection.
#include <memory>
#include <string>
#include <vector>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/grid_orb_extractor.hpp"

namespace keyfleet::agent {

class KeyframeTrigger {
 public:
  virtual ~KeyframeTrigger() = default;
  virtual bool is_keyframe(const Frame& frame) = 0;
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

struct OrbSlamTriggerParams {
  GridOrbParams orb;
  double image_scale = 0.5;     // frames are resized by this before feature extraction
  int max_frames = 30;          // ORB-SLAM2 mMaxFrames (= fps)
  int mapping_busy_frames = 2;  // local mapping is busy this long after a keyframe
  double ref_ratio = 0.9;       // monocular thRefRatio
  int min_inliers = 15;
  int lost_frames = 5;           // tracking lost this long: start again with a new keyframe
  double ransac_px = 1.0;        // epipolar distance threshold at full resolution
  double search_radius_px = 24;  // guided matching radius at full resolution
  int max_hamming = 50;          // ORB-SLAM2 TH_LOW
  double nn_ratio = 0.9;
};

// Emulates ORB-SLAM2's monocular Tracking::NeedNewKeyFrame on ORB features tracked against
// the reference (last) keyframe. Matching is guided as ORB-SLAM2's is: each reference feature
// is searched for within a radius around where a constant-velocity model puts it (the image
// shift of the previous frame), at a neighbouring scale, best Hamming distance under
// max_hamming and nn_ratio times the second best. inliers = matches consistent with a
// fundamental matrix (RANSAC); nRef = the reference keyframe's features that the first frame
// after it tracked (its trackable map points); both counts are medians over three frames.
// A new keyframe when
//   (frames since the last >= max_frames  OR  local mapping idle)
//   AND inliers < ref_ratio * nRef  AND  inliers > min_inliers.
class OrbSlamTrigger final : public KeyframeTrigger {
 public:
  explicit OrbSlamTrigger(const OrbSlamTriggerParams& params);
  bool is_keyframe(const Frame& frame) override;

  int last_inliers() const { return last_inliers_; }
  int reference_tracked() const { return reference_tracked_; }

 private:
  int track(const OrbFeatures& current);  // inliers against the reference keyframe

  OrbSlamTriggerParams params_;
  GridOrbExtractor extractor_;
  OrbFeatures reference_;
  bool has_reference_ = false;
  int reference_tracked_ = -1;  // nRef; -1 until the first frame after the keyframe
  int frames_since_ = 0;
  int lost_ = 0;
  int last_inliers_ = 0;
  cv::Point2f shift_{0, 0};  // image motion of the reference features in the last frame
  static constexpr std::size_t kSmoothing = 3;
  std::vector<int> recent_;  // inlier counts of the last frames since the keyframe
};

}  // namespace keyfleet::agent
