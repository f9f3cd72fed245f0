#pragma once
// Twelve generated street views, a sign in each, on streets no model here was trained on (seed
// 4242), scored by a text segmenter as Table III scores them: the views the shipped models'
// accuracy floors are stated on.
#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/segmenter_eval.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/vision/text_segmenter.hpp"
#include "test_support.hpp"

namespace keyfleet::test {

inline constexpr std::size_t kGeneratedViews = 12;

inline eval::SegmentationScores score_on_generated_views(vision::TextSegmenter& segmenter) {
  TempDir dir;
  ScenarioConfig config;
  config.seed = 4242;
  config.street.sign_probability = 1.0;
  scenario::generate_training_set(config, dir.path().string(), kGeneratedViews, null_logger());
  return eval::evaluate_on_pairs(segmenter, dir.path().string(), 0);
}

}  // namespace keyfleet::test
