#pragma once
// Offline evaluation of the selection strategies on a generated scenario's ground truth.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/agent/stage_clock.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/vision/text_segmenter.hpp"

namespace keyfleet::eval {

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

// Throws StartupError for a name that is not one of the strategies agent_config.hpp names.
SelectorConfig::Strategy strategy_from_string(const std::string& name);

// One drone of a scenario, decoded into memory (640x480: about 0.9 MB a frame).
struct DroneFrames {
  scenario::DroneInfo info;
  std::vector<scenario::FrameTruth> truth;  // truth[i] belongs to frames[i]
  std::vector<agent::Frame> frames;         // whole: what the station reads and describes
  // With decode_reduce > 1, the frames as the agent's selection sees them (decoded at
  // 1/decode_reduce, agent::Frame::full_size set); empty otherwise.
  std::vector<agent::Frame> reduced;
  const std::vector<agent::Frame>& for_selection() const {
    return reduced.empty() ? frames : reduced;
  }
};
// Throws StartupError for an unknown drone or an unreadable frame. `decode_reduce` is the
// agent's selector.decode_reduce.
DroneFrames load_drone_frames(const std::string& scenario_dir, const std::string& drone,
                              int decode_reduce = 1);

// The V-SLAM keyframes (frame indices, ascending) the trigger of `base` takes on the frames.
std::vector<std::uint64_t> run_vslam_trigger(const std::vector<agent::Frame>& frames,
                                             const SelectorConfig& base, double fps,
                                             double* ms_per_frame = nullptr);

// One strategy of `config` anchored on exactly these V-SLAM keyframes (thin them first for a
// lower density: `config.density` is ignored). `segmenter` is borrowed, and needed by the
// semantic strategies; `clock` (optional) receives the stages' CPU time.
std::vector<agent::Selection> select_on_keyframes(const std::vector<agent::Frame>& frames,
                                                  const std::vector<std::uint64_t>& keyframes,
                                                  const SelectorConfig& config,
                                                  vision::TextSegmenter* segmenter,
                                                  agent::StageClock* clock = nullptr);

// Remembers each frame's mask, keyed by the frame's pixel buffer, so that strategies and
// densities evaluated on the same decoded frames run the network once per frame. Only valid
// while those frames live: make one per set of frames.
class CachingSegmenter final : public vision::TextSegmenter {
 public:
  explicit CachingSegmenter(std::unique_ptr<vision::TextSegmenter> inner);
  std::vector<cv::Mat> segment(const std::vector<cv::Mat>& bgr_frames) override;
  const vision::SegmenterInfo& info() const override { return inner_->info(); }

  std::size_t frames_requested() const { return requested_; }
  std::size_t frames_segmented() const { return masks_.size(); }
  double cpu_ms() const { return cpu_ms_; }  // in the network, calling thread

 private:
  std::unique_ptr<vision::TextSegmenter> inner_;
  std::map<const std::uint8_t*, cv::Mat> masks_;
  std::size_t requested_ = 0;
  double cpu_ms_ = 0;
};

}  // namespace keyfleet::eval
