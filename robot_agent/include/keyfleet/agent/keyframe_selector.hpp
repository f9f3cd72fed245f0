#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/config.hpp"

namespace keyfleet::agent {

// A frame chosen for publication, with the V-SLAM keyframe it stands for and its scores.
struct Selection {
  Frame frame;
  std::uint64_t vslam_keyframe_index = 0;
  std::uint64_t window_first_frame = 0;
  std::uint64_t window_last_frame = 0;
  double quality_score = 0;
  double sharpness_score = 0;
  double semantic_score = 0;
};

struct SelectorStep {
  bool vslam_keyframe = false;      // the pushed frame is a V-SLAM keyframe (baseline event)
  std::vector<Selection> selected;  // frames chosen by this step (possibly earlier ones)
};

// Seam for keyframe selection: one synchronous step per frame. Selections may lag the
// frame that caused them (a window needs frames after its V-SLAM keyframe).
class KeyframeSelector {
 public:
  virtual ~KeyframeSelector() = default;
  virtual SelectorStep push(const Frame& frame) = 0;
  // End of stream: whatever the selector still holds that deserves publication.
  virtual std::vector<Selection> finish() = 0;
};

// The fixed-stride trigger: every `stride`-th frame is both the V-SLAM keyframe and the
// published one (a baseline for experiments and the placeholder for the full selection).
class StrideSelector final : public KeyframeSelector {
 public:
  explicit StrideSelector(int stride);
  SelectorStep push(const Frame& frame) override;
  std::vector<Selection> finish() override { return {}; }

 private:
  std::uint64_t stride_;
  std::uint64_t last_selected_ = 0;
};

std::unique_ptr<KeyframeSelector> make_selector(const SelectorConfig& config);

}  // namespace keyfleet::agent
