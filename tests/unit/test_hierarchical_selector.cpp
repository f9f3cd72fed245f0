// The hierarchical selector around V-SLAM keyframes, driven by a stride trigger and a test
// double segmenter: the known-best frame of a window wins, windows have the documented size
// and position and close on time, density and the vslam strategy keep the right keyframes,
// finish() flushes, a window without a sharp frame still yields a selection, and max_scored
// bounds the frames the segmenter scores per window.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/agent/keyframe_trigger.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/text_segmenter.hpp"
#include "test_support.hpp"

namespace keyfleet::agent {
namespace {

using Strategy = SelectorConfig::Strategy;
using vision::SegmenterInfo;
using vision::TextSegmenter;

constexpr double kFps = 30;
constexpr int kWidth = 320, kHeight = 240;

// --- frames ------------------------------------------------------------------------------------

// A street-like scene with signs: sharp edges, mid-grey overall.
cv::Mat make_scene() {
  cv::Mat image(kHeight, kWidth, CV_8UC3);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(std::uint8_t(90 + 60 * x / kWidth), std::uint8_t(110 + 40 * y / kHeight),
                    std::uint8_t(120 + 30 * (x + y) / (kWidth + kHeight)));
  cv::rectangle(image, cv::Rect(32, 40, 110, 60), cv::Scalar(200, 210, 220), cv::FILLED);
  cv::rectangle(image, cv::Rect(160, 120, 110, 80), cv::Scalar(40, 60, 50), cv::FILLED);
  cv::putText(image, "BAKERY", {38, 80}, cv::FONT_HERSHEY_SIMPLEX, 0.8, cv::Scalar(20, 20, 20), 2,
              cv::LINE_AA);
  cv::putText(image, "OPEN 24H", {40, 210}, cv::FONT_HERSHEY_DUPLEX, 0.64,
              cv::Scalar(240, 240, 240), 2, cv::LINE_AA);
  return image;
}

cv::Mat gaussian(const cv::Mat& image, double sigma) {
  cv::Mat out;
  cv::GaussianBlur(image, out, {0, 0}, sigma);
  return out;
}

// The scene as the camera saw it, from sharp to badly blurred.
struct Looks {
  cv::Mat sharp = make_scene();
  cv::Mat soft = gaussian(sharp, 0.7);     // a little less sharp than `sharp`
  cv::Mat blurred = gaussian(sharp, 2.5);  // clearly blurred
  cv::Mat smeared = gaussian(sharp, 8.0);  // no sharp edge left
  cv::Mat smudged = gaussian(sharp, 5.5);  // blurred, but less than `smeared`
};

const Looks& looks() {
  static const Looks instance;
  return instance;
}

// The frame index is written into pixel (0, 0) so that the test segmenter can tell frames
// apart whatever the selector copies.
void write_tag(cv::Mat& image, std::uint64_t index) {
  image.at<cv::Vec3b>(0, 0) =
      cv::Vec3b(std::uint8_t(index & 0xFF), std::uint8_t((index >> 8) & 0xFF), std::uint8_t(0xA5));
}

std::uint64_t read_tag(const cv::Mat& image) {
  const cv::Vec3b tag = image.at<cv::Vec3b>(0, 0);
  return std::uint64_t(tag[0]) | (std::uint64_t(tag[1]) << 8);
}

Frame make_frame(std::uint64_t index, const cv::Mat& look) {
  Frame frame;
  frame.index = index;
  frame.capture_time_ns = std::int64_t(double(index) * 1e9 / kFps);
  frame.image = look.clone();
  write_tag(frame.image, index);
  return frame;
}

// `count` frames that all look like `base`, except those listed in `special`.
std::vector<Frame> make_frames(std::uint64_t count, const cv::Mat& base,
                               const std::map<std::uint64_t, cv::Mat>& special = {}) {
  std::vector<Frame> frames;
  for (std::uint64_t i = 0; i < count; ++i) {
    const auto it = special.find(i);
    frames.push_back(make_frame(i, it == special.end() ? base : it->second));
  }
  return frames;
}

// --- test doubles ------------------------------------------------------------------------------

// What the segmenter was asked: the frame indices of every batch, in call order.
struct SegmenterLog {
  std::vector<std::vector<std::uint64_t>> batches;
};

// Returns the mask listed for each frame (by its tag), an empty mask otherwise.
class LookupSegmenter final : public TextSegmenter {
 public:
  LookupSegmenter(std::map<std::uint64_t, cv::Mat> masks, std::shared_ptr<SegmenterLog> log)
      : masks_(std::move(masks)), log_(std::move(log)) {
    info_.input_size = {64, 32};
    info_.classes = {"background", "text"};
    info_.target_classes = {1};
    info_.description = "test double";
  }
  std::vector<cv::Mat> segment(const std::vector<cv::Mat>& bgr_frames) override {
    std::vector<std::uint64_t> batch;
    std::vector<cv::Mat> out;
    for (const auto& frame : bgr_frames) {
      const std::uint64_t index = read_tag(frame);
      batch.push_back(index);
      const auto it = masks_.find(index);
      out.push_back(it != masks_.end() ? it->second.clone()
                                       : cv::Mat::zeros(info_.input_size, CV_8U));
    }
    log_->batches.push_back(batch);
    return out;
  }
  const SegmenterInfo& info() const override { return info_; }

 private:
  SegmenterInfo info_;
  std::map<std::uint64_t, cv::Mat> masks_;
  std::shared_ptr<SegmenterLog> log_;
};

// 64 x 32 masks (border band 3 px at border 0.1): text in the middle, or cut by the left edge.
cv::Mat centred_text_mask() {
  cv::Mat mask = cv::Mat::zeros(32, 64, CV_8U);
  mask(cv::Rect(24, 12, 16, 8)).setTo(255);  // 128 pixels, none in the band
  return mask;
}

cv::Mat border_text_mask() {
  cv::Mat mask = cv::Mat::zeros(32, 64, CV_8U);
  mask(cv::Rect(0, 10, 24, 12)).setTo(255);  // more text (288 px), but cut by the frame edge
  return mask;
}

// Keyframes exactly at the listed frame indices.
class ScriptedTrigger final : public KeyframeTrigger {
 public:
  explicit ScriptedTrigger(std::set<std::uint64_t> keyframes) : keyframes_(std::move(keyframes)) {}
  bool is_keyframe(const Frame& frame) override { return keyframes_.count(frame.index) > 0; }

 private:
  std::set<std::uint64_t> keyframes_;
};

// --- running the selector ----------------------------------------------------------------------

SelectorConfig config_for(Strategy strategy, int density = 1, int max_scored = 0) {
  SelectorConfig config;
  config.strategy = strategy;
  config.density = density;
  config.max_scored = max_scored;
  return config;
}

HierarchicalSelector selector_with(const SelectorConfig& config, int stride,
                                   std::map<std::uint64_t, cv::Mat> masks = {},
                                   std::shared_ptr<SegmenterLog> log = nullptr) {
  if (!log) log = std::make_shared<SegmenterLog>();
  return HierarchicalSelector(config, std::make_unique<StrideTrigger>(stride),
                              std::make_unique<LookupSegmenter>(std::move(masks), log), nullptr);
}

struct Emitted {
  std::uint64_t pushed = 0;  // the frame whose push() returned the selection
  Selection selection;
};

struct Stream {
  std::vector<std::uint64_t> vslam_keyframes;
  std::vector<Emitted> emitted;
};

Stream push_all(KeyframeSelector& selector, const std::vector<Frame>& frames) {
  Stream run;
  for (const auto& frame : frames) {
    const SelectorStep step = selector.push(frame);
    if (step.vslam_keyframe) run.vslam_keyframes.push_back(frame.index);
    for (const auto& selection : step.selected) run.emitted.push_back({frame.index, selection});
  }
  return run;
}

std::string describe(const std::vector<Emitted>& emitted) {
  std::ostringstream out;
  for (const auto& e : emitted)
    out << "[pushed " << e.pushed << ": frame " << e.selection.frame.index << " for keyframe "
        << e.selection.vslam_keyframe_index << ", window " << e.selection.window_first_frame << ".."
        << e.selection.window_last_frame << "] ";
  return out.str();
}

// --- tests -------------------------------------------------------------------------------------

TEST(HierarchicalSelectorTestFrames, BlurredLooksScoreBelowTheSharpOne) {
  // Preconditions of the tests below, checked on the selector's own scores.
  auto selector = selector_with(config_for(Strategy::kQuality), 30);
  const auto& l = looks();
  const auto sharp = selector.score(make_frame(1, l.sharp)),
             soft = selector.score(make_frame(2, l.soft)),
             blurred = selector.score(make_frame(3, l.blurred)),
             smudged = selector.score(make_frame(4, l.smudged)),
             smeared = selector.score(make_frame(5, l.smeared));
  EXPECT_GT(sharp.blur, soft.blur);
  EXPECT_GT(soft.blur, blurred.blur);
  EXPECT_GT(blurred.blur, smudged.blur);
  EXPECT_GT(smudged.blur, smeared.blur);
  const double gate = QualityConfig().sharpness_gate;
  EXPECT_GE(sharp.sharpness, gate);
  EXPECT_GE(soft.sharpness, gate);
  EXPECT_LT(smudged.sharpness, gate);
  EXPECT_LT(smeared.sharpness, gate);
}

TEST(HierarchicalSelector, QualityPicksTheOnlySharpFrameOfTheWindow) {
  // Stride 30: keyframe 0 is selected at once; keyframe 30 gets the window 20..35.
  for (std::uint64_t sharp : {21u, 27u, 30u, 33u}) {
    auto selector = selector_with(config_for(Strategy::kQuality), 30);
    const Stream run =
        push_all(selector, make_frames(36, looks().blurred, {{sharp, looks().sharp}}));
    ASSERT_EQ(run.emitted.size(), 2u) << describe(run.emitted);
    const Selection& s = run.emitted[1].selection;
    EXPECT_EQ(s.vslam_keyframe_index, 30u);
    EXPECT_EQ(s.frame.index, sharp) << describe(run.emitted);
    EXPECT_EQ(read_tag(s.frame.image), sharp) << "the selection carries the frame's own image";
    EXPECT_GT(s.quality_score, 0.0);
    EXPECT_LE(s.quality_score, 1.0);
    EXPECT_DOUBLE_EQ(s.sharpness_score, selector.score(make_frame(sharp, looks().sharp)).sharpness);
  }
}

TEST(HierarchicalSelector, FullPicksTheFrameWhoseTextIsCentred) {
  // Window 20..35 (16 frames): frame 27 is the sharpest but its text is cut by the border;
  // frame 23, a little softer, shows its text whole. Everything else is blurred.
  const std::uint64_t best_quality = 27, centred_text = 23;
  auto log = std::make_shared<SegmenterLog>();
  auto selector =
      selector_with(config_for(Strategy::kFull), 30,
                    {{best_quality, border_text_mask()}, {centred_text, centred_text_mask()}}, log);
  const auto frames = make_frames(36, looks().blurred,
                                  {{best_quality, looks().sharp}, {centred_text, looks().soft}});
  const Stream run = push_all(selector, frames);
  ASSERT_EQ(run.emitted.size(), 2u) << describe(run.emitted);
  const Selection& s = run.emitted[1].selection;
  EXPECT_EQ(s.frame.index, centred_text) << describe(run.emitted);
  EXPECT_DOUBLE_EQ(s.semantic_score, 128.0);  // 128 text pixels, none in the border band
  // Its mask's one component, from the 64 x 32 mask to the 320 x 240 frame, goes as a hint.
  EXPECT_EQ(s.text_regions, (std::vector<TextRegion>{{120, 90, 80, 60}}));

  // The segmenter ran once per window, on the top third (by quality) of the frames that
  // pass the sharpness gate, as one batch.
  ASSERT_EQ(log->batches.size(), 2u);
  EXPECT_EQ(log->batches[0], (std::vector<std::uint64_t>{0}));
  std::size_t passing = 0;
  for (std::uint64_t i = 20; i <= 35; ++i)
    passing += selector.score(frames[i]).sharpness >= QualityConfig().sharpness_gate;
  const auto& batch = log->batches[1];
  EXPECT_EQ(batch.size(), std::min<std::size_t>(16 / 3, passing));
  ASSERT_FALSE(batch.empty());
  EXPECT_NE(std::find(batch.begin(), batch.end(), best_quality), batch.end());
  EXPECT_NE(std::find(batch.begin(), batch.end(), centred_text), batch.end());
  for (std::uint64_t index : batch) {
    EXPECT_GE(index, 20u);
    EXPECT_LE(index, 35u);
  }
}

// selector.decode_reduce: frames decoded at half size are selected the same way, and their text
// regions are given in the whole frame's pixels (what the keyframe sent is).
TEST(HierarchicalSelector, RegionsOfAReducedFrameAreInTheWholeFramesPixels) {
  const std::uint64_t centred_text = 23;
  auto selector =
      selector_with(config_for(Strategy::kFull), 30, {{centred_text, centred_text_mask()}});
  auto frames = make_frames(36, looks().blurred, {{centred_text, looks().soft}});
  for (auto& frame : frames) frame.full_size = {2 * frame.image.cols, 2 * frame.image.rows};
  const Stream run = push_all(selector, frames);
  ASSERT_EQ(run.emitted.size(), 2u) << describe(run.emitted);
  EXPECT_EQ(run.emitted[1].selection.frame.index, centred_text);
  EXPECT_EQ(run.emitted[1].selection.text_regions, (std::vector<TextRegion>{{240, 180, 160, 120}}));
}

TEST(HierarchicalSelector, FramesDecodedNarrowerThanTheQualityStageWorksAtAreRefused) {
  auto selector = selector_with(config_for(Strategy::kQuality), 30);
  auto frames = make_frames(2, looks().sharp, {});
  frames[0].full_size = {2 * frames[0].image.cols, 2 * frames[0].image.rows};
  SelectorConfig config = config_for(Strategy::kQuality);
  config.quality.sharpness_width = frames[0].image.cols + 1;
  config.decode_reduce = 2;
  auto narrow = selector_with(config, 30);
  try {
    narrow.push(frames[0]);
    FAIL() << "expected StartupError";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("selector.decode_reduce: 2"), std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(selector.push(frames[0]));  // 320 wide: what the sharpness works at
}

TEST(HierarchicalSelector, FullFallsBackOnQualityWhenNoTextIsSeen) {
  auto selector = selector_with(config_for(Strategy::kFull), 30);
  const Stream run = push_all(
      selector, make_frames(36, looks().blurred, {{27, looks().sharp}, {23, looks().soft}}));
  ASSERT_EQ(run.emitted.size(), 2u) << describe(run.emitted);
  EXPECT_EQ(run.emitted[1].selection.frame.index, 27u);
  EXPECT_EQ(run.emitted[1].selection.semantic_score, 0.0);
}

TEST(HierarchicalSelector, WindowHoldsHalfTheGapTwoThirdsBeforeTheKeyframe) {
  // Stride 30 and one sharp frame per window, so the previous selection s is known. With
  // W = (k - s) / 2 the window for keyframe k is k - (W - W/3) .. k + W/3, and it is decided
  // when frame k + W/3 is pushed, not before.
  const std::map<std::uint64_t, cv::Mat> sharp = {
      {24, looks().sharp}, {50, looks().sharp}, {80, looks().sharp}, {110, looks().sharp}};
  auto selector = selector_with(config_for(Strategy::kQuality), 30);
  const Stream run = push_all(selector, make_frames(140, looks().blurred, sharp));
  EXPECT_EQ(run.vslam_keyframes, (std::vector<std::uint64_t>{0, 30, 60, 90, 120}));

  struct Expected {
    std::uint64_t keyframe, first, last, selected;
  };
  // s = 0 -> W 15; s = 24 -> W 18; s = 50 -> W 20; s = 80 -> W 20.
  const std::vector<Expected> expected = {
      {0, 0, 0, 0}, {30, 20, 35, 24}, {60, 48, 66, 50}, {90, 76, 96, 80}, {120, 106, 126, 110}};
  ASSERT_EQ(run.emitted.size(), expected.size()) << describe(run.emitted);
  std::uint64_t previous = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const Emitted& e = run.emitted[i];
    const Expected& x = expected[i];
    EXPECT_EQ(e.selection.vslam_keyframe_index, x.keyframe) << describe(run.emitted);
    EXPECT_EQ(e.selection.window_first_frame, x.first) << "keyframe " << x.keyframe;
    EXPECT_EQ(e.selection.window_last_frame, x.last) << "keyframe " << x.keyframe;
    EXPECT_EQ(e.pushed, x.last) << "keyframe " << x.keyframe << " decided too early or late";
    EXPECT_EQ(e.selection.frame.index, x.selected) << "keyframe " << x.keyframe;
    if (i > 0) {  // the same, from the rule rather than the table
      const std::uint64_t w = (x.keyframe - previous) / 2;
      EXPECT_EQ(e.selection.window_first_frame, x.keyframe - (w - w / 3));
      EXPECT_EQ(e.selection.window_last_frame, x.keyframe + w / 3);
    }
    previous = e.selection.frame.index;
  }
  EXPECT_TRUE(selector.finish().empty()) << "nothing was pending";
}

TEST(HierarchicalSelector, DensityTwoSelectsOncePerTwoVslamKeyframes) {
  auto selector = selector_with(config_for(Strategy::kQuality, 2), 30);
  Stream run = push_all(selector, make_frames(151, looks().blurred, {{50, looks().sharp}}));
  for (const auto& selection : selector.finish()) run.emitted.push_back({151, selection});
  EXPECT_EQ(run.vslam_keyframes, (std::vector<std::uint64_t>{0, 30, 60, 90, 120, 150}));
  ASSERT_EQ(run.emitted.size(), 3u) << describe(run.emitted);
  EXPECT_EQ(run.emitted[0].selection.vslam_keyframe_index, 0u);
  EXPECT_EQ(run.emitted[1].selection.vslam_keyframe_index, 60u);
  EXPECT_EQ(run.emitted[2].selection.vslam_keyframe_index, 120u);
  // Keyframe 60 after the selection at 0: W = 30, window 40..70, the sharp frame 50 wins.
  EXPECT_EQ(run.emitted[1].selection.window_first_frame, 40u);
  EXPECT_EQ(run.emitted[1].selection.window_last_frame, 70u);
  EXPECT_EQ(run.emitted[1].selection.frame.index, 50u);
  // Keyframe 120 after the selection at 50: W = 35, window 96..131.
  EXPECT_EQ(run.emitted[2].selection.window_first_frame, 96u);
  EXPECT_EQ(run.emitted[2].selection.window_last_frame, 131u);
}

TEST(HierarchicalSelector, VslamStrategySelectsExactlyTheKeyframes) {
  HierarchicalSelector selector(config_for(Strategy::kVslam), std::make_unique<StrideTrigger>(25),
                                nullptr, nullptr);
  const Stream run = push_all(selector, make_frames(110, looks().blurred, {{40, looks().sharp}}));
  EXPECT_EQ(run.vslam_keyframes, (std::vector<std::uint64_t>{0, 25, 50, 75, 100}));
  ASSERT_EQ(run.emitted.size(), run.vslam_keyframes.size()) << describe(run.emitted);
  for (std::size_t i = 0; i < run.emitted.size(); ++i) {
    const Emitted& e = run.emitted[i];
    EXPECT_EQ(e.pushed, run.vslam_keyframes[i]) << "published when it is a keyframe";
    EXPECT_EQ(e.selection.frame.index, run.vslam_keyframes[i]);
    EXPECT_EQ(e.selection.vslam_keyframe_index, run.vslam_keyframes[i]);
  }
  EXPECT_TRUE(selector.finish().empty());
}

TEST(HierarchicalSelector, FinishFlushesThePendingWindow) {
  // Keyframe 30's window (20..35) is still open when the stream ends at frame 32.
  auto selector = selector_with(config_for(Strategy::kQuality), 30);
  const Stream run = push_all(selector, make_frames(33, looks().blurred, {{31, looks().sharp}}));
  ASSERT_EQ(run.emitted.size(), 1u) << describe(run.emitted);
  const auto flushed = selector.finish();
  ASSERT_EQ(flushed.size(), 1u);
  EXPECT_EQ(flushed[0].vslam_keyframe_index, 30u);
  EXPECT_EQ(flushed[0].window_first_frame, 20u);
  EXPECT_EQ(flushed[0].window_last_frame, 32u) << "the window ends with the stream";
  EXPECT_EQ(flushed[0].frame.index, 31u) << "frames after the keyframe are candidates too";
  EXPECT_TRUE(selector.finish().empty()) << "flushed only once";
}

TEST(HierarchicalSelector, WindowWithoutASharpFrameStillYieldsTheLeastBad) {
  for (Strategy strategy : {Strategy::kQuality, Strategy::kFull}) {
    auto selector = selector_with(config_for(strategy), 30);
    const auto frames = make_frames(36, looks().smeared, {{26, looks().smudged}});
    for (std::uint64_t i = 20; i <= 35; ++i)
      ASSERT_LT(selector.score(frames[i]).sharpness, QualityConfig().sharpness_gate)
          << "frame " << i << " passes the gate";
    const Stream run = push_all(selector, frames);
    ASSERT_EQ(run.emitted.size(), 2u) << describe(run.emitted);
    EXPECT_EQ(run.emitted[1].selection.vslam_keyframe_index, 30u);
    EXPECT_EQ(run.emitted[1].selection.frame.index, 26u) << "the least blurred frame";
  }
}

TEST(HierarchicalSelector, KeyframeBeforeTheWindowClosesDecidesItWithoutRepeatingAFrame) {
  // Keyframe 60 opens the window 40..70 (W = 30 after the selection at 0); keyframe 62
  // arrives first and closes it with the frames before 62. Frame 62, the sharp one, belongs
  // to keyframe 62's own window and is published once, for it.
  HierarchicalSelector selector(
      config_for(Strategy::kQuality),
      std::make_unique<ScriptedTrigger>(std::set<std::uint64_t>{0, 60, 62}), nullptr, nullptr);
  Stream run = push_all(selector, make_frames(100, looks().blurred, {{62, looks().sharp}}));
  for (const auto& selection : selector.finish()) run.emitted.push_back({100, selection});
  ASSERT_GE(run.emitted.size(), 2u) << describe(run.emitted);
  EXPECT_EQ(run.emitted[1].selection.vslam_keyframe_index, 60u);
  EXPECT_EQ(run.emitted[1].selection.window_last_frame, 61u) << describe(run.emitted);
  EXPECT_NE(run.emitted[1].selection.frame.index, 62u);
  ASSERT_EQ(run.emitted.size(), 3u) << describe(run.emitted);
  EXPECT_EQ(run.emitted[2].selection.vslam_keyframe_index, 62u);
  EXPECT_EQ(run.emitted[2].selection.frame.index, 62u);
  std::set<std::uint64_t> published;
  for (const auto& e : run.emitted)
    EXPECT_TRUE(published.insert(e.selection.frame.index).second)
        << "frame " << e.selection.frame.index << " selected twice: " << describe(run.emitted);
}

// The segmenter's batch for keyframe 30's window (20..35, 16 frames, a third is 5) when every
// frame passes the sharpness gate: frame 27 is the sharpest, 23 the next, the rest soft.
std::vector<std::uint64_t> window_batch(Strategy strategy, int max_scored) {
  auto log = std::make_shared<SegmenterLog>();
  auto selector = selector_with(config_for(strategy, 1, max_scored), 30, {}, log);
  const auto frames = make_frames(36, looks().soft, {{27, looks().sharp}, {23, looks().sharp}});
  const Stream run = push_all(selector, frames);
  EXPECT_EQ(run.emitted.size(), 2u) << describe(run.emitted);
  EXPECT_EQ(log->batches.size(), 2u);
  return log->batches.size() == 2 ? log->batches[1] : std::vector<std::uint64_t>{};
}

TEST(HierarchicalSelector, MaxScoredDefaultsToTheThirdOfTheWindow) {
  EXPECT_EQ(SelectorConfig().max_scored, 0);
  EXPECT_EQ(parse_agent_config("", "agent.yaml").selector.max_scored, 0);
  for (Strategy strategy : {Strategy::kFull, Strategy::kSemantic}) {
    EXPECT_EQ(window_batch(strategy, 0).size(), 16u / 3);
    // A bound above the third changes nothing.
    EXPECT_EQ(window_batch(strategy, 6), window_batch(strategy, 0));
    EXPECT_EQ(window_batch(strategy, 5), window_batch(strategy, 0));
  }
}

TEST(HierarchicalSelector, MaxScoredBoundsTheSegmentersBatch) {
  // full: the best frames by quality, in quality order.
  const auto full_two = window_batch(Strategy::kFull, 2);
  ASSERT_EQ(full_two.size(), 2u);
  EXPECT_EQ(std::set<std::uint64_t>(full_two.begin(), full_two.end()),
            (std::set<std::uint64_t>{23, 27}));
  const auto full_one = window_batch(Strategy::kFull, 1);
  ASSERT_EQ(full_one.size(), 1u);
  EXPECT_EQ(full_one[0], full_two[0]) << "the first by quality is kept";
  const auto full_default = window_batch(Strategy::kFull, 0);
  EXPECT_TRUE(std::equal(full_two.begin(), full_two.end(), full_default.begin()))
      << "a bound keeps the head of the default batch";

  // semantic: fewer frames, still spread over the window.
  const auto spread = window_batch(Strategy::kSemantic, 2);
  ASSERT_EQ(spread.size(), 2u);
  EXPECT_EQ(spread, (std::vector<std::uint64_t>{20, 28}));
  EXPECT_EQ(window_batch(Strategy::kSemantic, 1), (std::vector<std::uint64_t>{20}));
}

TEST(HierarchicalSelector, MaxScoredIsReadFromYamlAndChecked) {
  EXPECT_EQ(parse_agent_config("selector:\n  max_scored: 2\n", "agent.yaml").selector.max_scored,
            2);
  EXPECT_THROW(parse_agent_config("selector:\n  max_scored: -1\n", "agent.yaml"), ConfigError);
  const AgentConfig two = parse_agent_config("selector:\n  max_scored: 3\n", "agent.yaml");
  EXPECT_EQ(parse_agent_config(to_yaml(two), "round-trip").selector.max_scored, 3);
}

TEST(HierarchicalSelector, SemanticStrategiesNeedASegmenter) {
  for (Strategy strategy : {Strategy::kSemantic, Strategy::kFull})
    EXPECT_THROW(HierarchicalSelector(config_for(strategy), std::make_unique<StrideTrigger>(30),
                                      nullptr, nullptr),
                 std::invalid_argument);
}

}  // namespace
}  // namespace keyfleet::agent
