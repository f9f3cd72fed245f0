#pragma once
#include <optional>

#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// What a keyframe is worth to the station, in [0, 1], for the order in which the outbox sends:
// the mean of three terms, each in [0, 1] and free of the scores' units:
// - text: its semantic score s against the mean m of the scores seen so far, s / (s + m)
//   (0 without text, 1/2 for a typical one, towards 1 for the most text);
// - quality: the selector's quality score (already normalised in its window);
// - novelty for place recognition: the distance d from the previous keyframe's camera position
//   against the mean distance D between keyframes, d / (d + D); 1/2 without poses.
class KeyframeValue {
 public:
  double operator()(double semantic_score, double quality_score, const std::optional<Pose>& pose);

 private:
  double semantic_sum_ = 0;
  double semantic_count_ = 0;
  double distance_sum_ = 0;
  double distance_count_ = 0;
  std::optional<Pose> previous_;
};

}  // namespace keyfleet::agent
