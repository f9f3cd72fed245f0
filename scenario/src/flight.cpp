#include "keyfleet/scenario/flight.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace keyfleet::scenario {
namespace {

constexpr double kPi = 3.14159265358979323846;
double radians(double degrees) { return degrees * kPi / 180.0; }
double uniform(std::mt19937_64& rng, double low, double high) {
  return std::uniform_real_distribution<double>(low, high)(rng);
}

}  // namespace

double Flight::Wave::at(double t) const {
  return amplitude * std::sin(2 * kPi * frequency_hz * t + phase);
}

Flight::Flight(const DroneFlightConfig& c, int day, std::uint64_t scenario_seed,
               std::mt19937_64& rng)
    : burst_s_(c.shake_burst_s) {
  // Offsets that differ per day make revisits look different; per drone, a little more.
  std::mt19937_64 day_rng(scenario_seed * 6364136223846793005ULL + std::uint64_t(day) * 104729ULL);
  const double day_altitude = uniform(day_rng, -1, 1) * c.altitude_jitter_m;
  const double day_lateral = uniform(day_rng, -1, 1) * c.lateral_jitter_m;
  speed_ = c.speed_mps + uniform(rng, -1, 1) * c.speed_jitter_mps;
  start_x_ = c.start_m + uniform(rng, 0, 1.0);
  altitude_ =
      std::max(0.5, c.altitude_m + day_altitude + uniform(rng, -0.3, 0.3) * c.altitude_jitter_m);
  lateral_ = c.lateral_offset_m + day_lateral + uniform(rng, -0.3, 0.3) * c.lateral_jitter_m;
  yaw_rad_ = radians(c.view_yaw_deg + uniform(rng, -5, 5));
  pitch_rad_ = radians(c.pitch_deg + uniform(rng, -3, 3));

  auto waves = [&](std::vector<Wave>& out, int n, double amplitude_deg, double f_low,
                   double f_high) {
    for (int i = 0; i < n; ++i)
      out.push_back(
          {radians(amplitude_deg) / n, uniform(rng, f_low, f_high), uniform(rng, 0, 2 * kPi)});
  };
  waves(heading_, 3, c.heading_jitter_deg, 0.03, 0.2);
  waves(shake_yaw_, 3, c.shake_deg, 4, 14);
  waves(shake_pitch_, 3, c.shake_deg, 4, 14);
  waves(shake_roll_, 3, c.shake_deg, 4, 14);
  waves(burst_yaw_, 2, c.shake_burst_deg, 6, 18);
  waves(burst_pitch_, 2, c.shake_burst_deg, 6, 18);
  waves(burst_roll_, 2, c.shake_burst_deg * 0.5, 6, 18);
  for (int i = 0; i < 3; ++i)  // metres, not degrees: bob of the airframe
    bob_.push_back({uniform(rng, 0.03, 0.12), uniform(rng, 0.1, 0.6), uniform(rng, 0, 2 * kPi)});
  if (c.shake_burst_rate_hz > 0) {
    std::exponential_distribution<double> gap(c.shake_burst_rate_hz);
    for (double t = gap(rng); t < 3600; t += gap(rng) + c.shake_burst_s) burst_starts_.push_back(t);
  }
}

bool Flight::in_shake_burst(double t) const {
  for (double start : burst_starts_) {
    if (start > t) break;
    if (t < start + burst_s_) return true;
  }
  return false;
}

Eigen::Matrix3d Flight::rotation_wc(double t) const {
  double yaw = yaw_rad_, pitch = pitch_rad_, roll = 0;
  for (const auto& w : heading_) yaw += w.at(t);
  for (const auto& w : shake_yaw_) yaw += w.at(t);
  for (const auto& w : shake_pitch_) pitch += w.at(t);
  for (const auto& w : shake_roll_) roll += w.at(t);
  for (double start : burst_starts_) {
    if (start > t) break;
    if (t < start + burst_s_) {
      const double envelope = std::sin(kPi * (t - start) / burst_s_);
      for (const auto& w : burst_yaw_) yaw += envelope * w.at(t);
      for (const auto& w : burst_pitch_) pitch += envelope * w.at(t);
      for (const auto& w : burst_roll_) roll += envelope * w.at(t);
    }
  }
  // Camera axes in the world: forward from yaw (toward +y = left) and pitch (up), then
  // right and down; roll turns about forward.
  const Eigen::Vector3d forward(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                                std::sin(pitch));
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.col(0) = right, r.col(1) = down, r.col(2) = forward;
  return r * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

CameraPose Flight::pose_at(double t) const {
  const Eigen::Matrix3d r_wc = rotation_wc(t);
  Eigen::Vector3d centre(start_x_ + speed_ * t, lateral_, altitude_);
  for (std::size_t i = 0; i < bob_.size(); ++i) centre[i] += bob_[i].at(t);
  CameraPose pose;
  pose.rotation_cw = r_wc.transpose();
  pose.translation_cw = -pose.rotation_cw * centre;
  return pose;
}

Pose Flight::camera_to_world(double t) const {
  const CameraPose pose = pose_at(t);
  const Eigen::Quaterniond q(pose.rotation_cw.transpose());
  const Eigen::Vector3d c = pose.centre();
  return Pose{c.x(), c.y(), c.z(), q.x(), q.y(), q.z(), q.w()};
}

}  // namespace keyfleet::scenario
