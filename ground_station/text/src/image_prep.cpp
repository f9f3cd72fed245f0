#include "image_prep.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace keyfleet::station {

double reading_scale(cv::Size size, int min_long_side, int max_long_side) {
  const int long_side = std::max(size.width, size.height);
  if (long_side <= 0) return 1.0;
  if (min_long_side > 0 && long_side < min_long_side) return double(min_long_side) / long_side;
  if (max_long_side > 0 && long_side > max_long_side) return double(max_long_side) / long_side;
  return 1.0;
}

cv::Mat rescaled(const cv::Mat& image, double scale) {
  if (std::abs(scale - 1.0) < 1e-3) return image;
  cv::Mat out;
  cv::resize(image, out, cv::Size(), scale, scale, scale > 1 ? cv::INTER_CUBIC : cv::INTER_AREA);
  return out;
}

void map_back(std::vector<ReadWord>& words, double scale, cv::Point origin, cv::Rect bounds) {
  for (auto& w : words) {
    const int x0 = int(std::floor(w.box.x / scale)) + origin.x;
    const int y0 = int(std::floor(w.box.y / scale)) + origin.y;
    const int x1 = int(std::ceil((w.box.x + w.box.width) / scale)) + origin.x;
    const int y1 = int(std::ceil((w.box.y + w.box.height) / scale)) + origin.y;
    w.box = cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1)) & bounds;
  }
}

}  // namespace keyfleet::station
