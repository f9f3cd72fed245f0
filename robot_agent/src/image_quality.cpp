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
  static const cv::Mat first_difference = (cv::Mat_<float>(1, 3) << -1, 0, 1);
  static const cv::Mat second_difference = (cv::Mat_<float>(1, 5) << 1, 0, -2, 0, 1);
  cv::Mat first, second;
  cv::filter2D(image, first, CV_32F, along_x ? first_difference : first_difference.t(), {-1, -1}, 0,
               cv::BORDER_REPLICATE);
  cv::filter2D(image, second, CV_32F, along_x ? second_difference : second_difference.t(), {-1, -1},
               0, cv::BORDER_REPLICATE);
  first = cv::abs(first);
  second = cv::abs(second);
  cv::boxFilter(first, first, -1, {3, 3}, {-1, -1}, false);
  cv::boxFilter(second, second, -1, {3, 3}, {-1, -1}, false);
  const cv::Mat edges = first > params.edge_contrast;
  const int edge_count = cv::countNonZero(edges);
  if (edge_count == 0) return 0;
  const cv::Mat sharp_edges = edges & (second > first * params.sharp_ratio);
  const int sharp = cv::countNonZero(sharp_edges);
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
