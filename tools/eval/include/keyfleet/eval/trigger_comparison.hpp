#pragma once
// Two V-SLAM triggers on the same frames: where their keyframes fall, and what each costs.
#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/frame_source.hpp"

namespace keyfleet::eval {

// How many of `keyframes` have one of `others` within `tolerance` frames.
std::size_t count_within(const std::vector<std::uint64_t>& keyframes,
                         const std::vector<std::uint64_t>& others, std::uint64_t tolerance);

struct TriggerRun {
  std::vector<std::uint64_t> keyframes;
  double cpu_ms_per_frame = 0;  // calling thread, the trigger alone
};

// One trigger over the frames (its own instance, max_frames 0 = fps).
TriggerRun run_trigger(const std::vector<agent::Frame>& frames, const TriggerConfig& config,
                       double fps);

struct TriggerComparison {
  std::string sequence;
  std::size_t frames = 0;
  TriggerRun reference, candidate;
  // Keyframes of one with a keyframe of the other within 2 and within 5 frames.
  std::size_t reference_within_2 = 0, reference_within_5 = 0;
  std::size_t candidate_within_2 = 0, candidate_within_5 = 0;
};

TriggerComparison compare_triggers(const std::string& sequence,
                                   const std::vector<agent::Frame>& frames, double fps,
                                   const TriggerConfig& reference, const TriggerConfig& candidate);

// A table, one line per comparison and a total line (keyframe counts, rates per 100 frames,
// agreement within +-2 and +-5 frames, CPU ms per frame of each).
std::string format_comparisons(const std::vector<TriggerComparison>& comparisons,
                               const std::string& reference_name,
                               const std::string& candidate_name);

}  // namespace keyfleet::eval
