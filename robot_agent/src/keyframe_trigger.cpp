#include "keyfleet/agent/keyframe_trigger.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <unordered_map>

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
    : params_(params), extractor_(params.orb), decision_(params.decision) {}

int OrbSlamTrigger::track(const OrbFeatures& current) {
  if (reference_.keypoints.size() < 8 || current.keypoints.size() < 8) return 0;
  // Index the current features on a grid for the radius search.
  const float cell = 16;
  const float radius = float(params_.search_radius_px * params_.image_scale);
  std::unordered_map<std::int64_t, std::vector<int>> grid;
  auto key = [](int cx, int cy) { return (std::int64_t(cx) << 32) ^ std::uint32_t(cy); };
  for (int j = 0; j < int(current.keypoints.size()); ++j) {
    const auto& p = current.keypoints[std::size_t(j)].pt;
    grid[key(int(p.x / cell), int(p.y / cell))].push_back(j);
  }
  std::vector<cv::Point2f> from, to;
  std::vector<int> used(current.keypoints.size(), -1);
  for (int i = 0; i < int(reference_.keypoints.size()); ++i) {
    const cv::KeyPoint& r = reference_.keypoints[std::size_t(i)];
    const cv::Point2f predicted = r.pt + shift_;
    int best = -1, best_d = 256, second_d = 256;
    for (int cy = int((predicted.y - radius) / cell); cy <= int((predicted.y + radius) / cell);
         ++cy)
      for (int cx = int((predicted.x - radius) / cell); cx <= int((predicted.x + radius) / cell);
           ++cx) {
        const auto it = grid.find(key(cx, cy));
        if (it == grid.end()) continue;
        for (const int j : it->second) {
          const cv::KeyPoint& c = current.keypoints[std::size_t(j)];
          if (std::abs(c.octave - r.octave) > 1 || cv::norm(c.pt - predicted) > radius) continue;
          const int d = cv::hal::normHamming(reference_.descriptors.ptr<std::uint8_t>(i),
                                             current.descriptors.ptr<std::uint8_t>(j),
                                             reference_.descriptors.cols);
          if (d < best_d)
            second_d = best_d, best_d = d, best = j;
          else if (d < second_d)
            second_d = d;
        }
      }
    if (best < 0 || best_d > params_.max_hamming || best_d > params_.nn_ratio * second_d) continue;
    if (used[std::size_t(best)] >= 0) continue;  // one-to-one
    used[std::size_t(best)] = i;
    from.push_back(r.pt);
    to.push_back(current.keypoints[std::size_t(best)].pt);
  }
  if (from.size() < 8) return int(from.size());
  std::vector<std::uint8_t> inlier;
  // Guided matches are mostly right: a few hundred RANSAC iterations suffice.
  const cv::Mat f =
      cv::findFundamentalMat(from, to, cv::FM_RANSAC, params_.ransac_px, 0.99, 200, inlier);
  if (f.empty()) return 0;
  // Constant-velocity model: the median shift of the inliers predicts the next frame.
  std::vector<float> dx, dy;
  for (std::size_t k = 0; k < inlier.size(); ++k)
    if (inlier[k]) dx.push_back(to[k].x - from[k].x), dy.push_back(to[k].y - from[k].y);
  if (!dx.empty()) {
    std::nth_element(dx.begin(), dx.begin() + long(dx.size() / 2), dx.end());
    std::nth_element(dy.begin(), dy.begin() + long(dy.size() / 2), dy.end());
    const cv::Point2f step(dx[dx.size() / 2], dy[dy.size() / 2]);
    const cv::Point2f velocity = step - shift_;  // image motion over the last frame
    shift_ = step + velocity;                    // where the next frame should see them
  }
  return int(dx.size());
}

cv::Size tracking_size(const Frame& frame, double image_scale) {
  const cv::Size full = frame_size(frame);
  return {std::max(1, int(std::lround(full.width * image_scale))),
          std::max(1, int(std::lround(full.height * image_scale)))};
}

bool OrbSlamTrigger::is_keyframe(const Frame& frame) {
  cv::Mat grey;
  cv::cvtColor(frame.image, grey, cv::COLOR_BGR2GRAY);
  const cv::Size size = tracking_size(frame, params_.image_scale);
  if (size != grey.size()) cv::resize(grey, grey, size, 0, 0, cv::INTER_AREA);
  OrbFeatures current = extractor_.extract(grey);
  if (decision_.started()) {
    last_inliers_ = track(current);
    if (!decision_.step(last_inliers_)) return false;
  }
  reference_ = std::move(current);
  shift_ = {0, 0};
  decision_.restart();
  return true;
}

}  // namespace keyfleet::agent
