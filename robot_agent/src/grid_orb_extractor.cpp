#include "keyfleet/agent/grid_orb_extractor.hpp"

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "keyfleet/vision/image_helpers.hpp"

namespace keyfleet::agent {
namespace {

constexpr int kPatchRadius = 15;  // rBRIEF patch 31 x 31
constexpr int kBorder = 19;       // keep descriptors inside the image

// Orientation from the intensity centroid of the circular patch around the corner.
float centroid_angle(const cv::Mat& image, cv::Point2f p) {
  double m01 = 0, m10 = 0;
  const int cx = cvRound(p.x), cy = cvRound(p.y);
  for (int dy = -kPatchRadius; dy <= kPatchRadius; ++dy) {
    const int half_width = int(std::sqrt(double(kPatchRadius * kPatchRadius - dy * dy)));
    const std::uint8_t* row = image.ptr<std::uint8_t>(cy + dy);
    for (int dx = -half_width; dx <= half_width; ++dx) {
      const double v = row[cx + dx];
      m10 += dx * v;
      m01 += dy * v;
    }
  }
  return float(cv::fastAtan2(float(m01), float(m10)));
}

// Keeps at most `quota` corners, the strongest of each grid cell first, round by round; the
// cells are sized so that the quota would fill each about once.
std::vector<cv::KeyPoint> spread(std::vector<cv::KeyPoint> corners, cv::Size size, int quota) {
  if (int(corners.size()) <= quota) return corners;
  const double cell = std::max(8.0, std::sqrt(double(size.area()) / quota));
  std::sort(corners.begin(), corners.end(),
            [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  std::vector<int> strongest_first(corners.size());
  std::iota(strongest_first.begin(), strongest_first.end(), 0);
  std::vector<cv::KeyPoint> kept;
  for (int i : vision::spread_over_grid(corners, strongest_first, size, cell, quota))
    kept.push_back(corners[std::size_t(i)]);
  return kept;
}

}  // namespace

GridOrbExtractor::GridOrbExtractor(const GridOrbParams& p) : params_(p) {
  const double f = 1.0 / p.scale_factor;
  double per = p.features * (1 - f) / (1 - std::pow(f, p.levels));
  int total = 0;
  for (int level = 0; level < p.levels - 1; ++level, per *= f) {
    per_level_.push_back(int(std::round(per)));
    total += per_level_.back();
  }
  per_level_.push_back(std::max(0, p.features - total));
  describer_ = cv::ORB::create(p.features, float(p.scale_factor), p.levels, kBorder, 0, 2,
                               cv::ORB::HARRIS_SCORE, 31, p.initial_fast_threshold);
}

OrbFeatures GridOrbExtractor::extract(const cv::Mat& grey) const {
  OrbFeatures out;
  std::vector<cv::KeyPoint> all;
  cv::Mat level_image = grey;
  for (int level = 0; level < params_.levels; ++level) {
    const double scale = std::pow(params_.scale_factor, level);
    if (level > 0)
      cv::resize(grey, level_image,
                 cv::Size(int(std::round(grey.cols / scale)), int(std::round(grey.rows / scale))),
                 0, 0, cv::INTER_LINEAR);
    const cv::Rect inner(kBorder, kBorder, level_image.cols - 2 * kBorder,
                         level_image.rows - 2 * kBorder);
    if (inner.width <= 0 || inner.height <= 0) break;
    std::vector<cv::KeyPoint> corners;
    for (int y = inner.y; y < inner.br().y; y += params_.cell_px)
      for (int x = inner.x; x < inner.br().x; x += params_.cell_px) {
        // Cells overlap by 3 pixels so that FAST's ring sees the neighbours.
        const cv::Rect cell = cv::Rect(x - 3, y - 3, params_.cell_px + 6, params_.cell_px + 6) &
                              cv::Rect(0, 0, level_image.cols, level_image.rows);
        std::vector<cv::KeyPoint> found;
        cv::FAST(level_image(cell), found, params_.initial_fast_threshold, true);
        if (found.empty()) cv::FAST(level_image(cell), found, params_.min_fast_threshold, true);
        for (auto& k : found) {
          k.pt += cv::Point2f(float(cell.x), float(cell.y));
          if (inner.contains(cv::Point(cvRound(k.pt.x), cvRound(k.pt.y)))) corners.push_back(k);
        }
      }
    for (auto& k : spread(corners, level_image.size(), per_level_[std::size_t(level)])) {
      k.angle = centroid_angle(level_image, k.pt);
      k.octave = level;
      k.size = float(31 * scale);
      k.pt *= float(scale);
      all.push_back(k);
    }
  }
  describer_->compute(grey, all, out.descriptors);
  out.keypoints = std::move(all);
  return out;
}

}  // namespace keyfleet::agent
