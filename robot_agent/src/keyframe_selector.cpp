#include "keyfleet/agent/keyframe_selector.hpp"

#include <stdexcept>

namespace keyfleet::agent {

StrideSelector::StrideSelector(int stride) : stride_(static_cast<std::uint64_t>(stride)) {
  if (stride < 1) throw std::invalid_argument("stride must be >= 1");
}

SelectorStep StrideSelector::push(const Frame& frame) {
  SelectorStep step;
  if (frame.index % stride_ != 0) return step;
  step.vslam_keyframe = true;
  Selection selection;
  selection.frame = frame;
  selection.vslam_keyframe_index = frame.index;
  selection.window_first_frame = frame.index == 0 ? 0 : last_selected_ + 1;
  selection.window_last_frame = frame.index;
  last_selected_ = frame.index;
  step.selected.push_back(std::move(selection));
  return step;
}

std::unique_ptr<KeyframeSelector> make_selector(const SelectorConfig& config) {
  switch (config.strategy) {
    case SelectorConfig::Strategy::kStride: return std::make_unique<StrideSelector>(config.stride);
  }
  throw std::invalid_argument("unknown selector strategy");
}

}  // namespace keyfleet::agent
