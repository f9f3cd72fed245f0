#include "keyfleet/agent/image_quality.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace keyfleet::agent {

double energy_of_laplacian(const cv::Mat& grey) {
  static const cv::Mat kernel = (cv::Mat_<float>(3, 3) << 1, 4, 1, 4, -20, 4, 1, 4, 1) / 6.0f;
  cv::Mat response;
  cv::filter2D(grey, response, CV_32F, kernel, {-1, -1}, 0, cv::BORDER_REPLICATE);
  return response.dot(response);
}

double brightness_score(const cv::Mat& bgr) {
  cv::Mat lab;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);  // 8-bit: L scaled to 0..255
  cv::Mat lightness;
  cv::extractChannel(lab, lightness, 0);
  lightness.convertTo(lightness, CV_32F, 100.0 / 255.0, -50.0);
  return 1.0 / (1.0 + lightness.dot(lightness));  // +1: a flat mid-grey frame stays finite
}

namespace {

constexpr double kMinEdgeFraction = 0.02;

// Fraction of edge pixels that are sharp, for differences taken along one axis.
double sharp_fraction(const cv::Mat& image, bool along_x, const SharpnessParams& params) {
  const int rows = image.rows, cols = image.cols;
  cv::Mat first = cv::Mat::zeros(rows, cols, CV_32F), second = cv::Mat::zeros(rows, cols, CV_32F);
  const int dx = along_x ? 1 : 0, dy = along_x ? 0 : 1;
  for (int y = 2 * dy; y < rows - 2 * dy; ++y) {
    float* f = first.ptr<float>(y);
    float* s = second.ptr<float>(y);
    for (int x = 2 * dx; x < cols - 2 * dx; ++x) {
      auto at = [&](int k) { return float(image.at<std::uint8_t>(y + k * dy, x + k * dx)); };
      f[x] = std::abs(at(1) - at(-1));
      s[x] = std::abs(at(2) - 2 * at(0) + at(-2));
    }
  }
  cv::boxFilter(first, first, -1, {3, 3}, {-1, -1}, false);
  cv::boxFilter(second, second, -1, {3, 3}, {-1, -1}, false);
  const cv::Mat edges = first > params.edge_contrast;
  const int edge_count = cv::countNonZero(edges);
  if (edge_count == 0) return 0;
  cv::Mat ratio;
  cv::divide(second, first, ratio);
  const int sharp = cv::countNonZero(edges & (ratio > params.sharp_ratio));
  // A heavily blurred frame keeps few edges, and the few left are noise that looks sharp:
  // below 2 % edge pixels the fraction is scaled down, which keeps the score monotone.
  const double scarcity = std::min(1.0, edge_count / (kMinEdgeFraction * double(image.total())));
  return double(sharp) / edge_count * scarcity;
}

}  // namespace

double kumar_sharpness(const cv::Mat& grey, const SharpnessParams& params) {
  cv::Mat smooth;
  cv::medianBlur(grey, smooth, 3);
  const double rx = sharp_fraction(smooth, true, params);
  const double ry = sharp_fraction(smooth, false, params);
  return std::min(rx, ry);
}

}  // namespace keyfleet::agent
