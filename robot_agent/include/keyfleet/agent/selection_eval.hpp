#pragma once
// Offline evaluation of the selection strategies on a generated scenario's ground truth.
#include <map>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/stage_clock.hpp"

namespace keyfleet::agent {

struct StrategyResult {
  std::string strategy;
  std::size_t vslam_keyframes = 0;
  std::size_t keyframes = 0;
  std::size_t distinct_full_words = 0;  // legible words fully visible in some selected frame
  std::size_t full_word_views = 0;      // (word, selected frame) pairs, fully visible
  double mean_blur_px = 0;              // ground-truth motion blur of the selected frames
  double mean_sharpness = 0;
  double cpu_ms_per_frame = 0;  // selection stages, trigger excluded
  std::vector<StageTime> stages;
};

struct SelectionEvaluation {
  std::string drone;
  std::size_t frames = 0;
  std::size_t words_in_sequence = 0;  // distinct legible words fully visible in any frame
  double trigger_ms_per_frame = 0;
  std::vector<StrategyResult> strategies;
};

// Runs the V-SLAM trigger of `base` once over the drone's frames, then each strategy on the
// same keyframes (so every strategy sends the same number of keyframes), and scores the
// selected frames against the scenario's ground truth.
SelectionEvaluation evaluate_selection(const std::string& scenario_dir, const std::string& drone,
                                       const SelectorConfig& base,
                                       const std::vector<SelectorConfig::Strategy>& strategies);

const char* to_string(SelectorConfig::Strategy strategy);

}  // namespace keyfleet::agent
