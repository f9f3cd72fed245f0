#pragma once
#include <opencv2/core.hpp>

#include <random>
#include <string>

#include "keyfleet/scenario/scenario_config.hpp"

namespace keyfleet::scenario {

struct AppliedEffects {
  double exposure_gain = 1;
  std::string exposure_event;  // "", "over", "under"
  double mean_level = 0;
};

// A linear motion-blur kernel of `length_px` along `angle_deg` (normalised, odd size).
cv::Mat motion_blur_kernel(double length_px, double angle_deg);

// The camera between the scene's radiance and the saved image: motion blur (given),
// auto-exposure with lag and random over/under-exposure events, vignetting, read and shot
// noise, optional greyscale and JPEG artefacts. Stateful (the exposure follows the scene).
class CameraEffects {
 public:
  CameraEffects(const CameraEffectsConfig& config, cv::Size size, double fps, std::uint64_t seed);
  cv::Mat apply(const cv::Mat& radiance, double blur_px, double blur_angle_deg,
                AppliedEffects& applied);

 private:
  CameraEffectsConfig config_;
  double frame_period_s_;
  std::mt19937_64 rng_;
  cv::Mat noise_bank_;  // CV_32FC3 standard normal, larger than a frame; cut at random offsets
  cv::Mat vignette_;    // CV_32FC3 factors
  double gain_ = -1;    // auto-exposure state; < 0 until the first frame
  double event_left_s_ = 0;
  std::string event_;
};

}  // namespace keyfleet::scenario
