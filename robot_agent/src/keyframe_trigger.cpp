#include "keyfleet/agent/keyframe_trigger.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "keyfleet/common/error.hpp"

namespace keyfleet::agent {

ListTrigger::ListTrigger(const std::string& path, double fps)
    : tolerance_ns_(std::int64_t(0.5e9 / fps)) {
  std::ifstream in(path);
  if (!in) throw StartupError("selector.trigger.list: cannot read keyframe list " + path);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double seconds = 0;
    if (!(fields >> seconds))
      throw StartupError(path + ":" + std::to_string(number) +
                         ": expected 'timestamp tx ty tz qx qy qz qw' (TUM format)");
    times_ns_.push_back(std::int64_t(std::llround(seconds * 1e9)));
  }
  if (times_ns_.empty()) throw StartupError(path + ": the keyframe list is empty");
  std::sort(times_ns_.begin(), times_ns_.end());
}

bool ListTrigger::is_keyframe(const Frame& frame) {
  const auto it =
      std::lower_bound(times_ns_.begin(), times_ns_.end(), frame.capture_time_ns - tolerance_ns_);
  return it != times_ns_.end() && *it < frame.capture_time_ns + tolerance_ns_;
}

OrbSlamTrigger::OrbSlamTrigger(const OrbSlamTriggerParams& params)
    : params_(params), extractor_(params.orb) {}

int OrbSlamTrigger::track(const OrbFeatures& current) const {
  if (reference_.keypoints.size() < 8 || current.keypoints.size() < 8) return 0;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(reference_.descriptors, current.descriptors, knn, 2);
  std::vector<cv::Point2f> from, to;
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance > 64 || m[0].distance > 0.8f * m[1].distance) continue;
    from.push_back(reference_.keypoints[std::size_t(m[0].queryIdx)].pt);
    to.push_back(current.keypoints[std::size_t(m[0].trainIdx)].pt);
  }
  if (from.size() < 8) return int(from.size());
  std::vector<std::uint8_t> inlier;
  const cv::Mat f = cv::findFundamentalMat(from, to, cv::FM_RANSAC,
                                           params_.ransac_px * params_.image_scale, 0.99, inlier);
  if (f.empty()) return 0;
  return cv::countNonZero(inlier);
}

bool OrbSlamTrigger::is_keyframe(const Frame& frame) {
  cv::Mat grey;
  cv::cvtColor(frame.image, grey, cv::COLOR_BGR2GRAY);
  if (params_.image_scale != 1.0)
    cv::resize(grey, grey, {}, params_.image_scale, params_.image_scale, cv::INTER_AREA);
  OrbFeatures current = extractor_.extract(grey);

  auto start_over = [&] {
    reference_ = std::move(current);
    has_reference_ = true;
    reference_tracked_ = -1;
    frames_since_ = 0;
    lost_ = 0;
    return true;
  };
  if (!has_reference_) return start_over();

  ++frames_since_;
  last_inliers_ = track(current);
  if (last_inliers_ <= params_.min_inliers) {
    if (++lost_ >= params_.lost_frames) return start_over();  // re-initialise on a new map
    return false;
  }
  lost_ = 0;
  if (reference_tracked_ < 0) {  // the reference keyframe's trackable points
    reference_tracked_ = last_inliers_;
    return false;
  }
  const bool timed_out = frames_since_ >= params_.max_frames;
  const bool mapping_idle = frames_since_ >= params_.mapping_busy_frames;
  const bool weak_tracking = last_inliers_ < params_.ref_ratio * reference_tracked_;
  if ((timed_out || mapping_idle) && weak_tracking) return start_over();
  return false;
}

}  // namespace keyfleet::agent
