#include "keyfleet/agent/semantic_score.hpp"

#include <algorithm>
#include <cmath>

namespace keyfleet::agent {

double semantic_score(const cv::Mat& text_mask, double border) {
  const int band = std::max(1, int(std::round(border * std::min(text_mask.rows, text_mask.cols))));
  const double text = cv::countNonZero(text_mask);
  const cv::Rect inner(band, band, text_mask.cols - 2 * band, text_mask.rows - 2 * band);
  const double inside = inner.area() > 0 ? cv::countNonZero(text_mask(inner)) : 0;
  return text / (1 + (text - inside));
}

}  // namespace keyfleet::agent
