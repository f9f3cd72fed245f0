#include "keyfleet/eval/selection_eval.hpp"

#include <algorithm>
#include <filesystem>
#include <set>

#include "keyfleet/common/clock.hpp"
#include "keyfleet/common/error.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

// Replays keyframe decisions made once, so that every strategy gets the same anchors.
class ReplayTrigger final : public agent::KeyframeTrigger {
 public:
  explicit ReplayTrigger(std::set<std::uint64_t> keyframes) : keyframes_(std::move(keyframes)) {}
  bool is_keyframe(const agent::Frame& frame) override { return keyframes_.count(frame.index) > 0; }

 private:
  std::set<std::uint64_t> keyframes_;
};

// Lends a segmenter to a selector that wants to own one.
class BorrowedSegmenter final : public vision::TextSegmenter {
 public:
  explicit BorrowedSegmenter(vision::TextSegmenter& inner) : inner_(inner) {}
  std::vector<cv::Mat> segment(const std::vector<cv::Mat>& bgr_frames) override {
    return inner_.segment(bgr_frames);
  }
  const vision::SegmenterInfo& info() const override { return inner_.info(); }

 private:
  vision::TextSegmenter& inner_;
};

std::set<std::string> full_words(const scenario::FrameTruth& truth) {
  std::set<std::string> words;
  for (const auto& w : truth.words)
    if (w.legible && w.visibility == scenario::WordVisibility::kFull)
      words.insert(std::to_string(w.sign_id));
  return words;
}

bool is_semantic(SelectorConfig::Strategy strategy) {
  return strategy == SelectorConfig::Strategy::kSemantic ||
         strategy == SelectorConfig::Strategy::kFull;
}

}  // namespace

SelectorConfig::Strategy strategy_from_string(const std::string& name) {
  if (const auto strategy = selection_strategy(name)) return *strategy;
  throw StartupError("unknown selection strategy '" + name + "' (" + selection_strategy_choices() +
                     ")");
}

DroneFrames load_drone_frames(const std::string& scenario_dir, const std::string& drone,
                              int decode_reduce) {
  const scenario::Scenario scenario = scenario::read_scenario(scenario_dir);
  const auto info = std::find_if(scenario.drones.begin(), scenario.drones.end(),
                                 [&](const auto& d) { return d.robot_id == drone; });
  if (info == scenario.drones.end())
    throw StartupError(scenario_dir + ": no drone '" + drone + "'");
  DroneFrames out;
  out.info = *info;
  const fs::path folder = fs::path(scenario_dir) / info->folder;
  out.truth = scenario::read_frame_truth(folder.string());
  std::vector<std::uint8_t> buffer;  // whole decodes: the current file, reused
  for (const auto& t : out.truth) {
    const std::string path = (folder / t.image).string();
    agent::Frame frame{t.index, t.timestamp_ns, {}, t.camera_to_world};
    if (!agent::read_frame_image(path, decode_reduce, buffer, frame))
      throw StartupError(path + ": cannot read the frame");
    if (frame.full_size.empty()) {  // decoded whole (decode_reduce 1, or not a JPEG)
      if (decode_reduce > 1) out.reduced.push_back(frame);
      out.frames.push_back(std::move(frame));
      continue;
    }
    // One read of the file: the whole frame comes from the bytes the reduced one kept.
    agent::Frame whole{t.index, t.timestamp_ns, agent::full_image(frame), t.camera_to_world};
    if (whole.image.empty()) throw StartupError(path + ": cannot decode the frame whole");
    out.frames.push_back(std::move(whole));
    out.reduced.push_back(std::move(frame));
  }
  return out;
}

std::vector<std::uint64_t> run_vslam_trigger(const std::vector<agent::Frame>& frames,
                                             const SelectorConfig& base, double fps,
                                             double* ms_per_frame) {
  SelectorConfig vslam = base;
  vslam.strategy = SelectorConfig::Strategy::kVslam;
  vslam.density = 1;
  auto selector = agent::make_selector(vslam, fps);
  std::vector<std::uint64_t> keyframes;
  const double start = thread_cpu_ms();
  for (const auto& frame : frames)
    if (selector->push(frame).vslam_keyframe) keyframes.push_back(frame.index);
  if (ms_per_frame)
    *ms_per_frame = frames.empty() ? 0 : (thread_cpu_ms() - start) / double(frames.size());
  return keyframes;
}

std::vector<agent::Selection> select_on_keyframes(const std::vector<agent::Frame>& frames,
                                                  const std::vector<std::uint64_t>& keyframes,
                                                  const SelectorConfig& config,
                                                  vision::TextSegmenter* segmenter,
                                                  agent::StageClock* clock) {
  SelectorConfig c = config;
  c.density = 1;
  std::unique_ptr<vision::TextSegmenter> lent;
  if (is_semantic(c.strategy)) {
    if (!segmenter)
      throw StartupError(std::string("the ") + to_string(c.strategy) +
                         " strategy needs a text segmenter");
    lent = std::make_unique<BorrowedSegmenter>(*segmenter);
  }
  agent::HierarchicalSelector selector(
      c,
      std::make_unique<ReplayTrigger>(std::set<std::uint64_t>(keyframes.begin(), keyframes.end())),
      std::move(lent), clock);
  std::vector<agent::Selection> selected;
  for (const auto& frame : frames)
    for (auto& s : selector.push(frame).selected) selected.push_back(std::move(s));
  for (auto& s : selector.finish()) selected.push_back(std::move(s));
  return selected;
}

CachingSegmenter::CachingSegmenter(std::unique_ptr<vision::TextSegmenter> inner)
    : inner_(std::move(inner)) {}

std::vector<cv::Mat> CachingSegmenter::segment(const std::vector<cv::Mat>& bgr_frames) {
  requested_ += bgr_frames.size();
  std::vector<cv::Mat> missing;
  for (const auto& f : bgr_frames)
    if (!masks_.count(f.data)) missing.push_back(f);
  if (!missing.empty()) {
    const double start = thread_cpu_ms();
    const auto fresh = inner_->segment(missing);  // one batch, as the selector would run it
    cpu_ms_ += thread_cpu_ms() - start;
    for (std::size_t i = 0; i < missing.size() && i < fresh.size(); ++i)
      masks_[missing[i].data] = fresh[i];
  }
  std::vector<cv::Mat> out;
  for (const auto& f : bgr_frames) {
    const auto it = masks_.find(f.data);
    out.push_back(it != masks_.end() ? it->second : cv::Mat());
  }
  return out;
}

SelectionEvaluation evaluate_selection(const std::string& scenario_dir, const std::string& drone,
                                       const SelectorConfig& base,
                                       const std::vector<SelectorConfig::Strategy>& strategies) {
  const DroneFrames drone_frames = load_drone_frames(scenario_dir, drone, base.decode_reduce);
  const auto& truth = drone_frames.truth;
  const auto& frames = drone_frames.for_selection();

  SelectionEvaluation evaluation;
  evaluation.drone = drone;
  evaluation.frames = frames.size();
  std::set<std::string> in_sequence;
  for (const auto& t : truth)
    for (const auto& w : full_words(t)) in_sequence.insert(w);
  evaluation.words_in_sequence = in_sequence.size();

  // The V-SLAM keyframes, once; `density` then keeps one of m, as the agent does.
  const auto all_keyframes =
      run_vslam_trigger(frames, base, drone_frames.info.fps, &evaluation.trigger_ms_per_frame);
  std::vector<std::uint64_t> keyframes;
  for (std::size_t i = 0; i < all_keyframes.size(); i += std::size_t(std::max(1, base.density)))
    keyframes.push_back(all_keyframes[i]);

  for (const auto strategy : strategies) {
    SelectorConfig config = base;
    config.strategy = strategy;
    agent::StageClock clock;
    std::unique_ptr<vision::TextSegmenter> segmenter;
    if (is_semantic(strategy)) segmenter = vision::make_text_segmenter(config.semantic);
    const auto selected = select_on_keyframes(frames, keyframes, config, segmenter.get(), &clock);

    StrategyResult result;
    result.strategy = to_string(strategy);
    result.vslam_keyframes = all_keyframes.size();
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

}  // namespace keyfleet::eval
