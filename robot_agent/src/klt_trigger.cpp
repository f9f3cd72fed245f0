#include "keyfleet/agent/klt_trigger.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace keyfleet::agent {

std::vector<cv::Point2f> spread_corners(const cv::Mat& whole, int max_points, int cell_px,
                                        int fast_threshold, int border_px) {
  const int b = std::max(0, std::min({border_px, (whole.cols - 1) / 2, (whole.rows - 1) / 2}));
  const cv::Mat grey = whole(cv::Rect(b, b, whole.cols - 2 * b, whole.rows - 2 * b));
  std::vector<cv::KeyPoint> all;
  cv::FAST(grey, all, fast_threshold, true);
  const int columns = (grey.cols + cell_px - 1) / cell_px;
  const int rows = (grey.rows + cell_px - 1) / cell_px;
  const std::size_t quota =
      std::size_t(std::max(1, (max_points + columns * rows - 1) / std::max(1, columns * rows)));
  std::vector<std::vector<const cv::KeyPoint*>> cells(std::size_t(columns * rows));
  for (const auto& k : all)
    cells[std::size_t(int(k.pt.y) / cell_px * columns + int(k.pt.x) / cell_px)].push_back(&k);
  auto stronger = [](const cv::KeyPoint* a, const cv::KeyPoint* b) {
    return a->response > b->response;
  };
  std::vector<const cv::KeyPoint*> kept;
  for (auto& cell : cells) {
    const std::size_t n = std::min(quota, cell.size());
    std::partial_sort(cell.begin(), cell.begin() + long(n), cell.end(), stronger);
    kept.insert(kept.end(), cell.begin(), cell.begin() + long(n));
  }
  if (kept.size() > std::size_t(max_points)) {
    std::nth_element(kept.begin(), kept.begin() + max_points, kept.end(), stronger);
    kept.resize(std::size_t(max_points));
  }
  std::vector<cv::Point2f> points;
  points.reserve(kept.size());
  for (const auto* k : kept) points.push_back(k->pt + cv::Point2f(float(b), float(b)));
  return points;
}

KltSlamTrigger::KltSlamTrigger(const KltTriggerParams& params)
    : params_(params),
      decision_(params.decision),
      tracker_(
          LucasKanadeParams{params.window_px, params.pyramid_levels, params.iterations, 0.03}) {}

void KltSlamTrigger::make_reference() {
  reference_points_ = spread_corners(grey_, params_.max_points, params_.cell_px,
                                     params_.fast_threshold, params_.border_px);
  previous_points_ = reference_points_;
  corners_ = reference_points_.size();
  ids_.resize(corners_);
  std::iota(ids_.begin(), ids_.end(), 0);
  tracker_.set_reference(grey_, reference_points_);
  step_ = {0, 0};
  decision_.restart();
}

int KltSlamTrigger::track() {
  if (reference_points_.size() < 8) return int(reference_points_.size());
  tracked_.resize(previous_points_.size());
  for (std::size_t i = 0; i < tracked_.size(); ++i) tracked_[i] = previous_points_[i] + step_;
  tracker_.track(grey_, ids_, tracked_, status_, error_);
  // Keep the corners tracked inside the border.
  const float b = float(params_.border_px);
  const cv::Rect2f inside(b, b, float(grey_.cols - 1) - 2 * b, float(grey_.rows - 1) - 2 * b);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < tracked_.size(); ++i) {
    if (!status_[i] || error_[i] > params_.max_error || !inside.contains(tracked_[i])) continue;
    reference_points_[kept] = reference_points_[i];
    previous_points_[kept] = previous_points_[i];
    ids_[kept] = ids_[i];
    tracked_[kept++] = tracked_[i];
  }
  ids_.resize(kept);
  reference_points_.resize(kept);
  previous_points_.resize(kept);
  tracked_.resize(kept);
  if (kept < 8) {
    previous_points_ = tracked_;
    return int(kept);
  }
  // Tracked corners are mostly right: a few hundred RANSAC iterations suffice.
  std::vector<std::uint8_t> inlier;
  const cv::Mat f = cv::findFundamentalMat(reference_points_, tracked_, cv::FM_RANSAC,
                                           params_.ransac_px, 0.99, 200, inlier);
  if (f.empty() || inlier.size() != kept) return 0;
  std::vector<float> dx, dy;
  kept = 0;
  for (std::size_t i = 0; i < inlier.size(); ++i) {
    if (!inlier[i]) continue;
    dx.push_back(tracked_[i].x - previous_points_[i].x);
    dy.push_back(tracked_[i].y - previous_points_[i].y);
    reference_points_[kept] = reference_points_[i];
    ids_[kept] = ids_[i];
    previous_points_[kept++] = tracked_[i];
  }
  ids_.resize(kept);
  reference_points_.resize(kept);
  previous_points_.resize(kept);
  if (!dx.empty()) {  // constant velocity: the next frame moves as this one did
    std::nth_element(dx.begin(), dx.begin() + long(dx.size() / 2), dx.end());
    std::nth_element(dy.begin(), dy.begin() + long(dy.size() / 2), dy.end());
    step_ = {dx[dx.size() / 2], dy[dy.size() / 2]};
  }
  return int(kept);
}

bool KltSlamTrigger::decide() {
  if (decision_.started()) {
    last_inliers_ = track();
    if (!decision_.step(last_inliers_)) return false;
  }
  make_reference();
  return true;
}

bool KltSlamTrigger::is_keyframe(const Frame& frame) {
  const cv::Size size = tracking_size(frame, params_.image_scale);
  const cv::Mat* colour = &frame.image;
  if (size != frame.image.size()) {
    resizer_.resize(frame.image, resized_, size);
    colour = &resized_;
  }
  cv::cvtColor(*colour, own_grey_, cv::COLOR_BGR2GRAY);
  grey_ = own_grey_;
  return decide();
}

bool KltSlamTrigger::is_keyframe_given_grey(const Frame& frame, const cv::Mat& grey) {
  const cv::Size size = tracking_size(frame, params_.image_scale);
  if (grey.size() != size || grey.type() != CV_8UC1) return is_keyframe(frame);
  grey_ = grey;
  return decide();
}

}  // namespace keyfleet::agent
