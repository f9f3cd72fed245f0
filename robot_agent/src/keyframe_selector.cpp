#include "keyfleet/agent/keyframe_selector.hpp"

#include "keyfleet/agent/semantic_score.hpp"
#include "keyfleet/agent/text_regions.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <numeric>

#include "keyfleet/agent/image_quality.hpp"
#include "keyfleet/agent/klt_trigger.hpp"
#include "keyfleet/common/error.hpp"

namespace keyfleet::agent {

HierarchicalSelector::HierarchicalSelector(const SelectorConfig& config,
                                           std::unique_ptr<KeyframeTrigger> trigger,
                                           std::unique_ptr<vision::TextSegmenter> segmenter,
                                           StageClock* clock)
    : config_(config),
      trigger_(std::move(trigger)),
      segmenter_(std::move(segmenter)),
      clock_(clock ? clock : &own_clock_) {
  const bool semantic = config.strategy == SelectorConfig::Strategy::kSemantic ||
                        config.strategy == SelectorConfig::Strategy::kFull;
  if (semantic && !segmenter_)
    throw std::invalid_argument("the semantic strategies need a text segmenter");
}

HierarchicalSelector::Scored HierarchicalSelector::score(const Frame& frame) {
  Scored s{frame, 0, 0, 0};
  if (config_.strategy == SelectorConfig::Strategy::kVslam) return s;
  // One area-resize of the frame serves both sizes: the sharpness width, then 112 x 112.
  {
    auto scope = clock_->measure("resize");
    images_.prepare(frame.image, config_.quality.size, config_.quality.sharpness_width);
  }
  {
    auto scope = clock_->measure("blur");
    s.blur = energy_of_laplacian(images_.grey);
  }
  {
    auto scope = clock_->measure("brightness");
    s.brightness = brightness_score(images_.small);
  }
  {
    auto scope = clock_->measure("sharpness");
    s.sharpness = kumar_sharpness(images_.work_grey,
                                  {config_.quality.edge_contrast, config_.quality.sharp_ratio},
                                  images_.sharpness);
  }
  return s;
}

void HierarchicalSelector::check_reduction(const Frame& frame) {
  if (reduction_checked_ || frame.full_size.empty() || frame.image.size() == frame.full_size)
    return;
  reduction_checked_ = true;
  int needed = 0;
  if (config_.strategy != SelectorConfig::Strategy::kVslam)
    needed = config_.quality.sharpness_width;
  if (segmenter_) needed = std::max(needed, segmenter_->info().input_size.width);
  if (frame.image.cols < needed)
    throw StartupError("selector.decode_reduce: " + std::to_string(config_.decode_reduce) +
                       " decodes the " + std::to_string(frame.full_size.width) + "x" +
                       std::to_string(frame.full_size.height) + " frames at " +
                       std::to_string(frame.image.cols) + "x" + std::to_string(frame.image.rows) +
                       ", narrower than the " + std::to_string(needed) +
                       " pixels the selection works at (quality.sharpness_width, the semantic "
                       "model's input): lower it");
}

SelectorStep HierarchicalSelector::push(const Frame& frame) {
  SelectorStep step;
  check_reduction(frame);
  buffer_.push_back(score(frame));
  {
    auto scope = clock_->measure("trigger");
    // The quality stage's grey image (when it ran) saves the trigger its own.
    step.vslam_keyframe = images_.work_grey.empty()
                              ? trigger_->is_keyframe(frame)
                              : trigger_->is_keyframe_given_grey(frame, images_.work_grey);
  }
  // A pending window whose future part has arrived is decided now.
  if (pending_ && frame.index >= pending_->last) {
    step.selected.push_back(resolve(*pending_));
    pending_.reset();
  }
  if (step.vslam_keyframe && vslam_keyframes_++ % std::uint64_t(config_.density) == 0) {
    if (pending_) {  // the next keyframe came first: decide with the frames before it
      pending_->last = std::max(pending_->first, frame.index - 1);
      step.selected.push_back(resolve(*pending_));
      pending_.reset();
    }
    const std::uint64_t k = frame.index;
    const std::uint64_t w = last_selected_ ? (k - *last_selected_) / 2 : 0;
    const std::uint64_t before = (2 * w + 2) / 3, after = w - before;
    Window window{k, k - std::min(before, k), k + after};
    if (config_.strategy == SelectorConfig::Strategy::kVslam || after == 0)
      step.selected.push_back(resolve(window));
    else
      pending_ = window;
  }
  trim_buffer();
  return step;
}

std::vector<Selection> HierarchicalSelector::finish() {
  std::vector<Selection> out;
  if (pending_) {
    out.push_back(resolve(*pending_));
    pending_.reset();
  }
  return out;
}

void HierarchicalSelector::trim_buffer() {
  const std::size_t keep = std::size_t(config_.max_window_frames);
  while (buffer_.size() > keep) buffer_.pop_front();
  // Frames before a pending window are never needed again.
  if (pending_)
    while (!buffer_.empty() && buffer_.front().frame.index < pending_->first) buffer_.pop_front();
}

Selection HierarchicalSelector::resolve(const Window& window) {
  std::vector<const Scored*> in_window;
  for (const auto& s : buffer_)
    if (s.frame.index >= window.first && s.frame.index <= window.last) in_window.push_back(&s);
  const Scored* keyframe = nullptr;
  for (const auto* s : in_window)
    if (s->frame.index == window.keyframe) keyframe = s;
  if (!keyframe) keyframe = in_window.back();  // clipped by max_window_frames

  Selection selection;
  selection.vslam_keyframe_index = window.keyframe;
  selection.window_first_frame = in_window.front()->frame.index;
  selection.window_last_frame = in_window.back()->frame.index;
  auto choose = [&](const Scored& s, double quality, double semantic) {
    selection.frame = s.frame;
    selection.quality_score = quality;
    selection.sharpness_score = s.sharpness;
    selection.semantic_score = semantic;
    last_selected_ = s.frame.index;
    return selection;
  };
  if (config_.strategy == SelectorConfig::Strategy::kVslam) return choose(*keyframe, 0, 0);

  // Quality: blur x brightness, each normalised by its maximum within the window.
  double max_blur = 0, max_bright = 0;
  for (const auto* s : in_window) {
    max_blur = std::max(max_blur, s->blur);
    max_bright = std::max(max_bright, s->brightness);
  }
  auto quality = [&](const Scored* s) {
    return (max_blur > 0 ? s->blur / max_blur : 0) *
           (max_bright > 0 ? s->brightness / max_bright : 0);
  };
  std::vector<const Scored*> candidates;
  for (const auto* s : in_window)
    if (s->sharpness >= config_.quality.sharpness_gate) candidates.push_back(s);
  if (candidates.empty()) candidates = in_window;  // nothing sharp: the least bad still goes
  std::stable_sort(candidates.begin(), candidates.end(),
                   [&](const Scored* a, const Scored* b) { return quality(a) > quality(b); });
  if (config_.strategy == SelectorConfig::Strategy::kQuality)
    return choose(*candidates.front(), quality(candidates.front()), 0);

  // Semantic: the text score of a few frames, as one batch.
  std::size_t q = std::max<std::size_t>(1, in_window.size() / 3);
  if (config_.max_scored > 0) q = std::min(q, std::size_t(config_.max_scored));
  std::vector<const Scored*> batch;
  if (config_.strategy == SelectorConfig::Strategy::kFull) {
    batch.assign(candidates.begin(), candidates.begin() + std::min(q, candidates.size()));
  } else {
    for (std::size_t i = 0; i < q; ++i) batch.push_back(in_window[i * in_window.size() / q]);
  }
  std::vector<cv::Mat> images;
  for (const auto* s : batch) images.push_back(s->frame.image);
  std::vector<cv::Mat> masks;
  {
    auto scope = clock_->measure("semantic");
    masks = segmenter_->segment(images);
  }
  std::size_t best = 0;
  double best_semantic = -1;
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const double semantic = semantic_score(masks[i], config_.semantic.border);
    // Strictly better text wins; the batch is in quality order, so ties keep quality.
    if (semantic > best_semantic) best_semantic = semantic, best = i;
  }
  Selection chosen = choose(*batch[best], quality(batch[best]), best_semantic);
  {
    auto scope = clock_->measure("text_regions");
    chosen.text_regions =
        text_regions(masks[best], frame_size(batch[best]->frame), config_.text_regions);
  }
  return chosen;
}

std::unique_ptr<KeyframeTrigger> make_trigger(const TriggerConfig& t, double fps) {
  NeedNewKeyframeParams decision;
  decision.max_frames = t.max_frames > 0 ? t.max_frames : std::max(1, int(std::lround(fps)));
  decision.mapping_busy_frames = t.mapping_busy_frames;
  decision.ref_ratio = t.ref_ratio;
  decision.min_inliers = t.min_inliers;
  switch (t.kind) {
    case TriggerConfig::Kind::kStride: return std::make_unique<StrideTrigger>(t.stride);
    case TriggerConfig::Kind::kList: return std::make_unique<ListTrigger>(t.list, fps);
    case TriggerConfig::Kind::kOrbSlam: {
      OrbSlamTriggerParams p;
      p.orb.features = t.features;
      p.orb.levels = t.levels;
      p.orb.scale_factor = t.scale_factor;
      p.image_scale = t.image_scale;
      p.decision = decision;
      return std::make_unique<OrbSlamTrigger>(p);
    }
    case TriggerConfig::Kind::kKlt: {
      KltTriggerParams p;
      p.decision = decision;
      p.decision.ref_ratio = t.klt.ref_ratio;
      p.image_scale = t.image_scale;
      p.max_points = t.klt.max_points;
      p.cell_px = t.klt.cell_px;
      p.fast_threshold = t.klt.fast_threshold;
      p.window_px = t.klt.window_px;
      p.pyramid_levels = t.klt.pyramid_levels;
      p.iterations = t.klt.iterations;
      p.max_error = t.klt.max_error;
      p.border_px = t.klt.border_px;
      return std::make_unique<KltSlamTrigger>(p);
    }
  }
  throw std::invalid_argument("unknown trigger kind");
}

std::unique_ptr<KeyframeSelector> make_selector(const SelectorConfig& config, double fps,
                                                StageClock* clock) {
  std::unique_ptr<KeyframeTrigger> trigger = make_trigger(config.trigger, fps);
  std::unique_ptr<vision::TextSegmenter> segmenter;
  if (config.strategy == SelectorConfig::Strategy::kSemantic ||
      config.strategy == SelectorConfig::Strategy::kFull)
    segmenter = vision::make_text_segmenter(config.semantic);
  return std::make_unique<HierarchicalSelector>(config, std::move(trigger), std::move(segmenter),
                                                clock);
}

}  // namespace keyfleet::agent
