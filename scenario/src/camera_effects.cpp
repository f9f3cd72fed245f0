#include "keyfleet/scenario/camera_effects.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace keyfleet::scenario {
namespace {

constexpr double kTargetLevel = 110;  // auto-exposure aims at this mean grey level
constexpr double kPi = 3.14159265358979323846;

}  // namespace

cv::Mat motion_blur_kernel(double length_px, double angle_deg) {
  const int size = (int(std::ceil(length_px)) | 1) + 2;
  cv::Mat kernel = cv::Mat::zeros(size, size, CV_32F);
  const double c = (size - 1) / 2.0, half = length_px / 2;
  const double dx = std::cos(angle_deg * kPi / 180) * half,
               dy = std::sin(angle_deg * kPi / 180) * half;
  // Sample the segment densely with bilinear splats: exact length, sub-pixel direction.
  const int samples = std::max(2, int(length_px * 8));
  for (int i = 0; i < samples; ++i) {
    const double s = -1 + 2.0 * i / (samples - 1);
    const double x = c + s * dx, y = c + s * dy;
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    kernel.at<float>(y0, x0) += float((1 - fx) * (1 - fy));
    kernel.at<float>(y0, x0 + 1) += float(fx * (1 - fy));
    kernel.at<float>(y0 + 1, x0) += float((1 - fx) * fy);
    kernel.at<float>(y0 + 1, x0 + 1) += float(fx * fy);
  }
  kernel /= cv::sum(kernel)[0];
  return kernel;
}

CameraEffects::CameraEffects(const CameraEffectsConfig& config, cv::Size size, double fps,
                             std::uint64_t seed)
    : config_(config), frame_period_s_(1.0 / fps), rng_(seed) {
  // Drawing a million normal samples per frame costs more than the rendering: draw a bank
  // once and cut each frame's noise from it at a random offset.
  noise_bank_.create(size.height * 2, size.width * 2, CV_32FC3);
  cv::RNG bank_rng(seed ^ 0x9E3779B97F4A7C15ULL);
  bank_rng.fill(noise_bank_, cv::RNG::NORMAL, 0, 1);
  cv::Mat v(size, CV_32F);
  const double cx = size.width / 2.0, cy = size.height / 2.0;
  const double r_max2 = cx * cx + cy * cy;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      v.at<float>(y, x) =
          float(1 - config.vignetting * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r_max2);
  cv::merge(std::vector<cv::Mat>{v, v, v}, vignette_);
}

cv::Mat CameraEffects::apply(const cv::Mat& radiance, double blur_px, double blur_angle_deg,
                             AppliedEffects& applied) {
  cv::Mat image;
  if (blur_px >= 0.7)
    cv::filter2D(radiance, image, -1, motion_blur_kernel(blur_px, blur_angle_deg), {-1, -1}, 0,
                 cv::BORDER_REFLECT);
  else
    image = radiance.clone();
  cv::multiply(image, vignette_, image);

  // Auto-exposure: first-order lag toward the gain that brings the mean to the target.
  const cv::Scalar mean = cv::mean(image);
  const double luminance = std::max(1.0, 0.114 * mean[0] + 0.587 * mean[1] + 0.299 * mean[2]);
  const double wanted = kTargetLevel / luminance;
  if (gain_ < 0 || config_.auto_exposure_lag_s <= 0)
    gain_ = wanted;
  else
    gain_ += (wanted - gain_) * (1 - std::exp(-frame_period_s_ / config_.auto_exposure_lag_s));
  if (event_left_s_ <= 0) {
    event_.clear();
    std::uniform_real_distribution<double> unit(0, 1);
    if (unit(rng_) < config_.exposure_event_rate_hz * frame_period_s_) {
      event_ = unit(rng_) < 0.5 ? "over" : "under";
      event_left_s_ = config_.exposure_event_s;
    }
  }
  double gain = gain_;
  if (!event_.empty()) {
    gain *= event_ == "over" ? config_.over_exposure_gain : config_.under_exposure_gain;
    event_left_s_ -= frame_period_s_;
  }
  image *= gain;

  // Read noise plus photon (shot) noise that grows with the signal.
  cv::Mat sigma;
  cv::max(image, 0, sigma);
  sigma.convertTo(sigma, CV_32F, config_.shot_noise * config_.shot_noise,
                  config_.noise_sigma * config_.noise_sigma);
  cv::sqrt(sigma, sigma);
  std::uniform_int_distribution<int> dx(0, noise_bank_.cols - image.cols);
  std::uniform_int_distribution<int> dy(0, noise_bank_.rows - image.rows);
  const cv::Mat noise = noise_bank_(cv::Rect(dx(rng_), dy(rng_), image.cols, image.rows));
  cv::Mat scaled;
  cv::multiply(noise, sigma, scaled);
  image += scaled;

  cv::Mat out;
  image.convertTo(out, CV_8UC3);
  if (config_.greyscale) {
    cv::Mat grey;
    cv::cvtColor(out, grey, cv::COLOR_BGR2GRAY);
    cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  }
  if (config_.jpeg_artifact_quality > 0) {
    std::vector<std::uint8_t> bytes;
    cv::imencode(".jpg", out, bytes, {cv::IMWRITE_JPEG_QUALITY, config_.jpeg_artifact_quality});
    out = cv::imdecode(bytes, cv::IMREAD_COLOR);
  }
  applied.exposure_gain = gain;
  applied.exposure_event = event_;
  const cv::Scalar level = cv::mean(out);
  applied.mean_level = 0.114 * level[0] + 0.587 * level[1] + 0.299 * level[2];
  return out;
}

}  // namespace keyfleet::scenario
