#include "keyfleet/station/places/orb_extractor.hpp"

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "keyfleet/vision/image_helpers.hpp"

namespace keyfleet::station {
namespace {

// Indices of at most `quota` keypoints: the strongest of every cell first, round by round.
std::vector<int> spread(const std::vector<cv::KeyPoint>& keypoints, cv::Size size, int cell_px,
                        int quota) {
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return keypoints[std::size_t(a)].response > keypoints[std::size_t(b)].response;
  });
  std::vector<int> kept =
      vision::spread_over_grid(keypoints, order, size, double(std::max(8, cell_px)), quota);
  std::sort(kept.begin(), kept.end());
  return kept;
}

}  // namespace

OrbFeatures extract_orb(const cv::Mat& image, const OrbParams& params) {
  OrbFeatures out;
  const cv::Mat grey = vision::to_grey(image);
  if (grey.empty()) return out;
  const int features = std::max(1, params.features);
  const float scale = params.scale > 1.0f ? params.scale : 1.2f;
  const int levels = std::clamp(params.levels, 1, 16);
  const float oversample = std::max(1.0f, params.oversample);

  cv::Mat work = grey;
  double factor = 1.0;
  if (params.min_width > 0 && grey.cols < params.min_width) {
    factor = double(params.min_width) / grey.cols;
    cv::resize(grey, work, cv::Size(), factor, factor, cv::INTER_LINEAR);
  }
  const int detect = int(std::lround(features * oversample));
  auto orb = cv::ORB::create(detect, scale, levels, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31,
                             std::clamp(params.fast_threshold, 1, 255));
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  orb->detectAndCompute(work, cv::noArray(), keypoints, descriptors);
  if (keypoints.empty() || descriptors.rows != int(keypoints.size())) return out;

  if (int(keypoints.size()) > features) {
    const auto kept = spread(keypoints, work.size(), params.cell_px, features);
    out.descriptors.create(int(kept.size()), descriptors.cols, descriptors.type());
    out.keypoints.reserve(kept.size());
    for (std::size_t i = 0; i < kept.size(); ++i) {
      descriptors.row(kept[i]).copyTo(out.descriptors.row(int(i)));
      out.keypoints.push_back(keypoints[std::size_t(kept[i])]);
    }
  } else {
    out.keypoints = std::move(keypoints);
    out.descriptors = descriptors;
  }
  if (factor != 1.0) {
    for (auto& k : out.keypoints) {
      k.pt.x = float(k.pt.x / factor);
      k.pt.y = float(k.pt.y / factor);
      k.size = float(k.size / factor);
    }
  }
  return out;
}

}  // namespace keyfleet::station
