#pragma once
// The quality scores written plainly with OpenCV operations on float images, as the agent
// computed them before the fused implementation (image_quality.hpp): the reference that the
// tests hold the fast scores to and the baseline the benchmarks compare them with.
#include <opencv2/core.hpp>

#include "keyfleet/agent/image_quality.hpp"

namespace keyfleet::eval::reference {

double energy_of_laplacian(const cv::Mat& grey);
double brightness_score(const cv::Mat& bgr);
double kumar_sharpness(const cv::Mat& grey, const agent::SharpnessParams& params);

}  // namespace keyfleet::eval::reference
