#include "keyfleet/station/orb_extractor.hpp"

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace keyfleet::station {
namespace {

cv::Mat to_grey(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U) return {};
  if (image.channels() == 1) return image;
  cv::Mat grey;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  return grey;
}

// Indices of at most `quota` keypoints: the strongest of every cell first, round by round.
std::vector<int> spread(const std::vector<cv::KeyPoint>& keypoints, cv::Size size, int cell_px,
                        int quota) {
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return keypoints[std::size_t(a)].response > keypoints[std::size_t(b)].response;
  });
  const int cell = std::max(8, cell_px);
  const int cols = (size.width + cell - 1) / cell, rows = (size.height + cell - 1) / cell;
  std::vector<std::vector<int>> cells(std::size_t(cols * rows));
  for (int i : order) {
    const auto& p = keypoints[std::size_t(i)].pt;
    const int cx = std::clamp(int(p.x) / cell, 0, cols - 1);
    const int cy = std::clamp(int(p.y) / cell, 0, rows - 1);
    cells[std::size_t(cy * cols + cx)].push_back(i);
  }
  std::vector<int> kept;
  for (std::size_t round = 0; int(kept.size()) < quota; ++round) {
    bool any = false;
    for (const auto& c : cells) {
      if (round >= c.size() || int(kept.size()) >= quota) continue;
      kept.push_back(c[round]);
      any = true;
    }
    if (!any) break;
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

}  // namespace

OrbFeatures extract_orb(const cv::Mat& image, const OrbParams& params) {
  OrbFeatures out;
  const cv::Mat grey = to_grey(image);
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
