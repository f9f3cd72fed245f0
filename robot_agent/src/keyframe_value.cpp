#include "keyfleet/agent/keyframe_value.hpp"

#include <algorithm>
#include <cmath>

namespace keyfleet::agent {
namespace {

double ratio_term(double x, double mean) {
  if (x <= 0) return 0.0;
  if (mean <= 0) return 1.0;
  return x / (x + mean);
}

}  // namespace

double KeyframeValue::operator()(double semantic_score, double quality_score,
                                 const std::optional<Pose>& pose) {
  const double semantic = std::max(0.0, semantic_score);
  semantic_sum_ += semantic;
  semantic_count_ += 1;
  const double text = ratio_term(semantic, semantic_sum_ / semantic_count_);

  double novelty = 0.5;
  if (pose && previous_) {
    const double d =
        std::hypot(pose->tx - previous_->tx, pose->ty - previous_->ty, pose->tz - previous_->tz);
    distance_sum_ += d;
    distance_count_ += 1;
    novelty = ratio_term(d, distance_sum_ / distance_count_);
  }
  if (pose) previous_ = pose;

  const double quality = std::clamp(quality_score, 0.0, 1.0);
  return (text + quality + novelty) / 3.0;
}

}  // namespace keyfleet::agent
