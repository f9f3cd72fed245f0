#include "keyfleet/eval/image_quality_reference.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>

namespace keyfleet::eval::reference {
namespace {

double sharp_fraction(const cv::Mat& image, bool along_x, const agent::SharpnessParams& params) {
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
  const int sharp = cv::countNonZero(edges & (second > first * params.sharp_ratio));
  return double(sharp) / edge_count * std::min(1.0, edge_count / (0.02 * double(image.total())));
}

}  // namespace

double energy_of_laplacian(const cv::Mat& grey) {
  static const cv::Mat kernel = (cv::Mat_<float>(3, 3) << 1, 4, 1, 4, -20, 4, 1, 4, 1) / 6.0f;
  cv::Mat response;
  cv::filter2D(grey, response, CV_32F, kernel, {-1, -1}, 0, cv::BORDER_REPLICATE);
  return response.dot(response);
}

double brightness_score(const cv::Mat& bgr) {
  cv::Mat lab, lightness;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);
  cv::extractChannel(lab, lightness, 0);
  lightness.convertTo(lightness, CV_64F, 100.0 / 255.0, -50.0);
  return 1.0 / (1.0 + lightness.dot(lightness));
}

double kumar_sharpness(const cv::Mat& grey, const agent::SharpnessParams& params) {
  cv::Mat smooth;
  cv::medianBlur(grey, smooth, 3);
  return std::min(sharp_fraction(smooth, true, params), sharp_fraction(smooth, false, params));
}

}  // namespace keyfleet::eval::reference
