#include "keyfleet/agent/selection_eval.hpp"

#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <set>

#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/common/clock.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/scenario_truth.hpp"

namespace keyfleet::agent {
namespace {

namespace fs = std::filesystem;

// Replays keyframe decisions made once, so that every strategy gets the same anchors.
class ReplayTrigger final : public KeyframeTrigger {
 public:
  explicit ReplayTrigger(std::set<std::uint64_t> keyframes) : keyframes_(std::move(keyframes)) {}
  bool is_keyframe(const Frame& frame) override { return keyframes_.count(frame.index) > 0; }

 private:
  std::set<std::uint64_t> keyframes_;
};

std::set<std::string> full_words(const scenario::FrameTruth& truth) {
  std::set<std::string> words;
  for (const auto& w : truth.words)
    if (w.legible && w.visibility == scenario::WordVisibility::kFull)
      words.insert(std::to_string(w.sign_id));
  return words;
}

}  // namespace

const char* to_string(SelectorConfig::Strategy strategy) {
  switch (strategy) {
    case SelectorConfig::Strategy::kVslam: return "vslam";
    case SelectorConfig::Strategy::kQuality: return "quality";
    case SelectorConfig::Strategy::kSemantic: return "semantic";
    case SelectorConfig::Strategy::kFull: return "full";
  }
  return "?";
}

SelectionEvaluation evaluate_selection(const std::string& scenario_dir, const std::string& drone,
                                       const SelectorConfig& base,
                                       const std::vector<SelectorConfig::Strategy>& strategies) {
  const scenario::Scenario scenario = scenario::read_scenario(scenario_dir);
  const auto info = std::find_if(scenario.drones.begin(), scenario.drones.end(),
                                 [&](const auto& d) { return d.robot_id == drone; });
  if (info == scenario.drones.end())
    throw StartupError(scenario_dir + ": no drone '" + drone + "'");
  const fs::path folder = fs::path(scenario_dir) / info->folder;
  const auto truth = scenario::read_frame_truth(folder.string());

  std::vector<Frame> frames;
  for (const auto& t : truth)
    frames.push_back({t.index, t.timestamp_ns,
                      cv::imread((folder / t.image).string(), cv::IMREAD_COLOR),
                      t.camera_to_world});

  SelectionEvaluation evaluation;
  evaluation.drone = drone;
  evaluation.frames = frames.size();
  std::set<std::string> in_sequence;
  for (const auto& t : truth)
    for (const auto& w : full_words(t)) in_sequence.insert(w);
  evaluation.words_in_sequence = in_sequence.size();

  // The V-SLAM keyframes, once.
  SelectorConfig vslam = base;
  vslam.strategy = SelectorConfig::Strategy::kVslam;
  std::set<std::uint64_t> keyframes;
  {
    auto selector = make_selector(vslam, info->fps);
    const double start = thread_cpu_ms();
    for (const auto& frame : frames)
      if (selector->push(frame).vslam_keyframe) keyframes.insert(frame.index);
    evaluation.trigger_ms_per_frame = (thread_cpu_ms() - start) / double(frames.size());
  }

  for (const auto strategy : strategies) {
    SelectorConfig config = base;
    config.strategy = strategy;
    StageClock clock;
    std::unique_ptr<TextSegmenter> segmenter;
    if (strategy == SelectorConfig::Strategy::kSemantic ||
        strategy == SelectorConfig::Strategy::kFull)
      segmenter = std::make_unique<DnnTextSegmenter>(locate_model(config.semantic.model),
                                                     config.semantic.threads);
    HierarchicalSelector selector(config, std::make_unique<ReplayTrigger>(keyframes),
                                  std::move(segmenter), &clock);
    std::vector<Selection> selected;
    for (const auto& frame : frames)
      for (auto& s : selector.push(frame).selected) selected.push_back(std::move(s));
    for (auto& s : selector.finish()) selected.push_back(std::move(s));

    StrategyResult result;
    result.strategy = to_string(strategy);
    result.vslam_keyframes = keyframes.size();
    result.keyframes = selected.size();
    std::set<std::string> seen;
    for (const auto& s : selected) {
      const auto& t = truth.at(s.frame.index);
      const auto words = full_words(t);
      result.full_word_views += words.size();
      seen.insert(words.begin(), words.end());
      result.mean_blur_px += t.motion_blur_px / double(selected.size());
      result.mean_sharpness += s.sharpness_score / double(selected.size());
    }
    result.distinct_full_words = seen.size();
    result.stages = clock.snapshot();
    double cpu = 0;
    for (const auto& stage : result.stages)
      if (stage.stage != "trigger") cpu += stage.cpu_ms_total;
    result.cpu_ms_per_frame = cpu / double(frames.size());
    evaluation.strategies.push_back(result);
  }
  return evaluation;
}

}  // namespace keyfleet::agent
