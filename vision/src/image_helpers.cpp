#include "keyfleet/vision/image_helpers.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace keyfleet::vision {

cv::Mat to_grey(const cv::Mat& image, int min_side) {
  if (image.empty() || image.depth() != CV_8U || image.dims != 2) return {};
  if (image.cols < min_side || image.rows < min_side) return {};
  cv::Mat grey;
  switch (image.channels()) {
    case 1: return image;
    case 3: cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY); break;
    default: return {};
  }
  return grey;
}

std::vector<int> spread_over_grid(const std::vector<cv::KeyPoint>& keypoints,
                                  const std::vector<int>& strongest_first, cv::Size image_size,
                                  double cell_px, int quota) {
  const int cols = std::max(1, int(std::ceil(image_size.width / cell_px)));
  const int rows = std::max(1, int(std::ceil(image_size.height / cell_px)));
  std::vector<std::vector<int>> cells(std::size_t(cols * rows));
  for (int i : strongest_first) {
    const cv::Point2f& p = keypoints[std::size_t(i)].pt;
    const int cx = std::clamp(int(p.x / cell_px), 0, cols - 1);
    const int cy = std::clamp(int(p.y / cell_px), 0, rows - 1);
    cells[std::size_t(cy * cols + cx)].push_back(i);
  }
  std::vector<int> kept;
  for (std::size_t round = 0; int(kept.size()) < quota; ++round) {
    bool any = false;
    for (const auto& cell : cells) {
      if (round >= cell.size() || int(kept.size()) >= quota) continue;
      kept.push_back(cell[round]);
      any = true;
    }
    if (!any) break;
  }
  return kept;
}

}  // namespace keyfleet::vision
