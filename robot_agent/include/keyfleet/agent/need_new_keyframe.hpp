#pragma once
// ORB-SLAM2's monocular Tracking::NeedNewKeyFrame, apart from how the inliers are counted: the
// decision both V-SLAM triggers (ORB matching, KLT tracking) take on their per-frame counts.
#include <cstddef>
#include <vector>

namespace keyfleet::agent {

struct NeedNewKeyframeParams {
  int max_frames = 30;          // ORB-SLAM2 mMaxFrames (= fps)
  int mapping_busy_frames = 2;  // local mapping is busy this long after a keyframe
  double ref_ratio = 0.9;       // monocular thRefRatio
  int min_inliers = 15;
  int lost_frames = 5;  // tracking lost this long: start again with a new keyframe
};

// Fed the inlier count of each frame against the reference keyframe. nRef = the reference's
// points that the first frames after it tracked (its trackable map points). Single-frame
// counts jump by +-15 % with blur and noise, where ORB-SLAM2's counts over a local map do not:
// both sides of the test use the median of three frames. A new keyframe when
//   (frames since the last >= max_frames  OR  local mapping idle)
//   AND inliers < ref_ratio * nRef  AND  inliers > min_inliers,
// or when tracking has been lost (inliers <= min_inliers) for lost_frames frames in a row.
class NeedNewKeyframe {
 public:
  explicit NeedNewKeyframe(const NeedNewKeyframeParams& params) : params_(params) {}

  // The caller made the current frame its reference keyframe.
  void restart();
  // true: the frame with these inliers becomes the new reference keyframe (restart() follows).
  bool step(int inliers);

  bool started() const { return started_; }
  int reference_tracked() const { return reference_tracked_; }

 private:
  NeedNewKeyframeParams params_;
  bool started_ = false;
  int reference_tracked_ = -1;  // nRef; -1 until the first frames after the keyframe
  int frames_since_ = 0;
  int lost_ = 0;
  static constexpr std::size_t kSmoothing = 3;
  std::vector<int> recent_;  // inlier counts of the last frames since the keyframe
};

}  // namespace keyfleet::agent
