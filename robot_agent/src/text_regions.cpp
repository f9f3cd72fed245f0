#include "keyfleet/agent/text_regions.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace keyfleet::agent {
namespace {

struct Box {
  double x0, y0, x1, y1;  // frame pixels
  double height() const { return y1 - y0; }
};

// Side by side on one line: enough vertical overlap, and a horizontal gap (negative when they
// overlap) small against their height.
bool same_line(const Box& a, const Box& b, const TextRegionsConfig& c) {
  const double overlap = std::min(a.y1, b.y1) - std::max(a.y0, b.y0);
  const double smaller = std::min(a.height(), b.height());
  if (smaller <= 0 || overlap < c.min_line_overlap * smaller) return false;
  const double gap = std::max(a.x0, b.x0) - std::min(a.x1, b.x1);
  return gap <= c.merge_gap * std::max(a.height(), b.height());
}

// Merges until no pair is left to merge (a merged box may reach a third).
void merge_lines(std::vector<Box>& boxes, const TextRegionsConfig& c) {
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < boxes.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < boxes.size() && !merged; ++j) {
        if (!same_line(boxes[i], boxes[j], c)) continue;
        Box& a = boxes[i];
        const Box& b = boxes[j];
        a = {std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1),
             std::max(a.y1, b.y1)};
        boxes.erase(boxes.begin() + long(j));
        merged = true;
      }
  }
}

}  // namespace

std::vector<TextRegion> text_regions(const cv::Mat& text_mask, cv::Size frame_size,
                                     const TextRegionsConfig& config) {
  if (!config.enabled || config.max_regions <= 0 || text_mask.empty() ||
      text_mask.type() != CV_8U || frame_size.empty())
    return {};
  const double sx = double(frame_size.width) / text_mask.cols;
  const double sy = double(frame_size.height) / text_mask.rows;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(text_mask != 0, labels, stats, centroids, 8);
  std::vector<Box> boxes;
  for (int i = 1; i < n; ++i) {  // 0 is the background
    if (stats.at<int>(i, cv::CC_STAT_AREA) * sx * sy < config.min_area_px) continue;
    const double x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const double w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    boxes.push_back({x * sx, y * sy, (x + w) * sx, (y + h) * sy});
  }
  merge_lines(boxes, config);
  std::vector<TextRegion> out;
  for (const Box& b : boxes) {
    const int x0 = std::clamp(int(std::floor(b.x0)), 0, frame_size.width);
    const int y0 = std::clamp(int(std::floor(b.y0)), 0, frame_size.height);
    const int x1 = std::clamp(int(std::ceil(b.x1)), 0, frame_size.width);
    const int y1 = std::clamp(int(std::ceil(b.y1)), 0, frame_size.height);
    const auto u16 = [](int v) { return std::uint16_t(std::min(v, 65535)); };
    if (x1 > x0 && y1 > y0) out.push_back({u16(x0), u16(y0), u16(x1 - x0), u16(y1 - y0)});
  }
  std::stable_sort(out.begin(), out.end(), [](const TextRegion& a, const TextRegion& b) {
    return int(a.w) * a.h > int(b.w) * b.h;
  });
  if (out.size() > std::size_t(config.max_regions)) out.resize(std::size_t(config.max_regions));
  return out;
}

}  // namespace keyfleet::agent
