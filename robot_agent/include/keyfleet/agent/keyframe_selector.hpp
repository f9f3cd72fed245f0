#pragma once
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/image_quality.hpp"
#include "keyfleet/agent/keyframe_trigger.hpp"
#include "keyfleet/agent/stage_clock.hpp"
#include "keyfleet/vision/text_segmenter.hpp"

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
  // Where the segmenter saw text in the chosen frame (semantic strategies; text_regions.hpp).
  std::vector<TextRegion> text_regions;
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

// Hierarchical selection around V-SLAM keyframes (Alonso et al., ICRA 2019). With the
// last selection at frame s and a new V-SLAM keyframe at k, the window holds W = (k - s) / 2
// frames, two thirds before k and one third after (so W/3 frames are buffered). `quality`
// picks the best blur x brightness score (each normalised by its maximum in the window)
// among frames that pass the sharpness gate; `full` runs the segmenter on the top W/3 of
// those as one batch and picks the best text score (quality breaks ties and decides when no
// text is seen); `semantic` scores up to W/3 frames spread over the window; `vslam` publishes
// the V-SLAM keyframe itself. `density` keeps one of every m V-SLAM keyframes. A positive
// `max_scored` caps the frames scored per window below W/3 (for `full`, the best by quality).
class HierarchicalSelector final : public KeyframeSelector {
 public:
  HierarchicalSelector(const SelectorConfig& config, std::unique_ptr<KeyframeTrigger> trigger,
                       std::unique_ptr<vision::TextSegmenter> segmenter, StageClock* clock);
  SelectorStep push(const Frame& frame) override;
  std::vector<Selection> finish() override;

  struct Scored {
    Frame frame;
    double blur = 0, brightness = 0, sharpness = 0;
  };
  // The scores of one frame (what push() computes for every frame), on reused buffers.
  Scored score(const Frame& frame);

 private:
  struct Window {
    std::uint64_t keyframe, first, last;
  };
  Selection resolve(const Window& window);
  void trim_buffer();
  // Refuses (StartupError) frames decoded narrower than the quality and semantic stages work
  // at (selector.decode_reduce too large for the frame); checked on the first reduced frame.
  void check_reduction(const Frame& frame);

  SelectorConfig config_;
  std::unique_ptr<KeyframeTrigger> trigger_;
  std::unique_ptr<vision::TextSegmenter> segmenter_;
  StageClock* clock_;
  StageClock own_clock_;
  std::deque<Scored> buffer_;
  std::optional<Window> pending_;
  std::optional<std::uint64_t> last_selected_;
  std::uint64_t vslam_keyframes_ = 0;
  bool reduction_checked_ = false;
  QualityImages images_;  // the per-frame scoring's buffers
};

// The configured V-SLAM trigger; max_frames 0 means `fps`. Throws StartupError when a keyframe
// list cannot be read.
std::unique_ptr<KeyframeTrigger> make_trigger(const TriggerConfig& config, double fps);

// Builds the configured trigger, segmenter (for the semantic strategies) and selector.
// Throws StartupError when a model or keyframe list cannot be used.
std::unique_ptr<KeyframeSelector> make_selector(const SelectorConfig& config, double fps,
                                                StageClock* clock = nullptr);

}  // namespace keyfleet::agent
