#include "keyfleet/agent/need_new_keyframe.hpp"

#include <algorithm>

namespace keyfleet::agent {

void NeedNewKeyframe::restart() {
  started_ = true;
  reference_tracked_ = -1;
  recent_.clear();
  frames_since_ = 0;
  lost_ = 0;
}

bool NeedNewKeyframe::step(int inliers) {
  ++frames_since_;
  if (inliers <= params_.min_inliers) return ++lost_ >= params_.lost_frames;  // a new map
  lost_ = 0;
  recent_.push_back(inliers);
  if (recent_.size() > kSmoothing) recent_.erase(recent_.begin());
  if (recent_.size() < kSmoothing) return false;
  std::vector<int> sorted = recent_;
  std::nth_element(sorted.begin(), sorted.begin() + kSmoothing / 2, sorted.end());
  const int tracked = sorted[kSmoothing / 2];
  if (reference_tracked_ < 0) {  // the reference keyframe's trackable points
    reference_tracked_ = tracked;
    return false;
  }
  const bool timed_out = frames_since_ >= params_.max_frames;
  const bool mapping_idle = frames_since_ >= params_.mapping_busy_frames;
  const bool weak_tracking = tracked < params_.ref_ratio * reference_tracked_;
  return (timed_out || mapping_idle) && weak_tracking;
}

}  // namespace keyfleet::agent
