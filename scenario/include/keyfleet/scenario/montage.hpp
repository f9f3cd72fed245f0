#pragma once
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace keyfleet::scenario {

struct MontageOptions {
  std::vector<std::string> drones;    // empty = all
  std::vector<std::uint64_t> frames;  // empty = five spread over the flight
  int tile_width = 320;
  bool draw_words = false;  // outline ground-truth words: green full, yellow cut, red occluded
};

// A grid of frames from a generated scenario, one row per drone, labelled with the drone,
// its day and the frame index. Throws std::runtime_error on a malformed scenario.
cv::Mat scenario_montage(const std::string& scenario_dir, const MontageOptions& options);

}  // namespace keyfleet::scenario
