#pragma once
#include <random>
#include <vector>

#include "keyfleet/scenario/plane_renderer.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

namespace keyfleet::scenario {

// One drone's flight along the street: a smooth path with slow heading wander, continuous
// high-frequency shake and random bursts of strong shake. Every term is a function of
// time, so the pose at any instant (inside an exposure too) is known exactly.
class Flight {
 public:
  // `rng` is the drone's own stream; offsets shared by a day derive from the scenario seed.
  Flight(const DroneFlightConfig& config, int day, std::uint64_t scenario_seed,
         std::mt19937_64& rng);

  CameraPose pose_at(double t) const;
  Pose camera_to_world(double t) const;
  bool in_shake_burst(double t) const;

 private:
  struct Wave {
    double amplitude, frequency_hz, phase;
    double at(double t) const;
  };
  Eigen::Matrix3d rotation_wc(double t) const;  // camera-to-world rotation

  double speed_, start_x_, altitude_, lateral_;
  double yaw_rad_, pitch_rad_;
  std::vector<Wave> heading_, shake_yaw_, shake_pitch_, shake_roll_, bob_;
  std::vector<Wave> burst_yaw_, burst_pitch_, burst_roll_;
  std::vector<double> burst_starts_;
  double burst_s_;
};

}  // namespace keyfleet::scenario
