#include "keyfleet/agent/link_aware_sender.hpp"

#include "keyfleet/agent/level_encoding.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace keyfleet::agent {
namespace {

constexpr std::uint64_t kCalibrateEvery = 30;  // selections between two calibrations
constexpr std::int64_t kUpdatePeriodNs = 200'000'000;
// Bytes a keyframe sample carries beside its image (ids, scores, pose, region hints, CDR).
constexpr std::uint64_t kSampleOverhead = 300;

}  // namespace

double link_prior_bytes_per_s(const DdsLinkProfile& link) {
  constexpr double kWirePerPayload = 1.3;
  return link.rate_kbit_s * 1000.0 / 8.0 * link.pacing / kWirePerPayload;
}

LinkAwareSender::LinkAwareSender(const LinkAdaptationConfig& config, const ImageCodec& codec,
                                 int jpeg_quality, double prior_bytes_per_s,
                                 std::function<std::uint64_t()> backlog_bytes, Logger logger)
    : config_(config),
      codec_(codec),
      logger_(std::move(logger)),
      estimator_(config.estimator_window_s),
      controller_(config, jpeg_quality),
      backlog_bytes_(std::move(backlog_bytes)) {
  estimator_.set_prior(prior_bytes_per_s);
}

void LinkAwareSender::station_matched(bool matched, std::int64_t now_ns) {
  if (matched)
    estimator_.resume(now_ns);
  else
    estimator_.pause(now_ns);
}

void LinkAwareSender::apply(std::int64_t now_ns) {
  last_update_ns_ = now_ns;
  const std::uint64_t backlog = backlog_bytes_();
  const LinkEstimate link = estimator_.estimate(now_ns);
  room_for_held_ = SendController::backlog_wait_s(link, backlog) < config_.latency_target_s / 4;
  const auto change = controller_.update(now_ns, link, backlog);
  if (!change) return;
  ++level_changes_;
  const auto& ladder = controller_.ladder();
  logger_->info("link adaptation: level {} -> {} ({}): {}", change->from, change->to,
                describe(ladder[change->to]), change->reason);
}

void LinkAwareSender::update(std::int64_t now_ns) {
  if (config_.enabled && now_ns - last_update_ns_ >= kUpdatePeriodNs) apply(now_ns);
}

void LinkAwareSender::calibrate(const cv::Mat& frame, const std::vector<TextRegion>& regions) {
  const auto& ladder = controller_.ladder();
  for (std::size_t i = 0; i < ladder.size(); ++i) {
    if (i > 0 && ladder[i].jpeg_quality == ladder[i - 1].jpeg_quality &&
        ladder[i].scale == ladder[i - 1].scale)
      continue;  // a density rung: the same encoding as the one above
    const EncodedFrame encoded = encode_at_level(frame, regions, ladder[i], config_.text_aware,
                                                 config_.text_margin_px, codec_);
    controller_.on_cost(i, encoded.image.size() + kSampleOverhead);
  }
}

LinkAwareSender::Encoded LinkAwareSender::encode(
    const cv::Mat& frame, const std::vector<TextRegion>& regions, std::int64_t now_ns,
    const std::function<const std::vector<std::uint8_t>&()>& richest) {
  Encoded out;
  if (config_.enabled) {
    if (selections_ % kCalibrateEvery == 0) calibrate(frame, regions);
    controller_.on_selection(now_ns);
    apply(now_ns);
  }
  ++selections_;
  const std::size_t index = controller_.level_index();
  const SendLevel& level = controller_.level();
  const SendLevel& richest_level = controller_.ladder()[0];
  if (level.scale == 1.0 && level.jpeg_quality == richest_level.jpeg_quality) {
    out.image = richest();
    out.width = static_cast<std::uint32_t>(frame.cols);
    out.height = static_cast<std::uint32_t>(frame.rows);
    out.text_regions = regions;
  } else {
    EncodedFrame encoded =
        encode_at_level(frame, regions, level, config_.text_aware, config_.text_margin_px, codec_);
    out.image = std::move(encoded.image);
    out.width = encoded.width;
    out.height = encoded.height;
    out.text_regions = std::move(encoded.text_regions);
    out.reduced = true;
  }
  if (config_.enabled) controller_.on_cost(index, out.image.size() + kSampleOverhead);
  out.held = !controller_.send_now();
  if (out.reduced) ++reduced_;
  if (out.held) ++thinned_;
  return out;
}

void LinkAwareSender::fill(AgentStats& stats, std::int64_t now_ns) const {
  const LinkEstimate e = estimator_.estimate(now_ns);
  const SendLevel& level = controller_.level();
  stats.keyframes_reduced = reduced_;
  stats.keyframes_thinned = thinned_;
  stats.level_changes = level_changes_;
  stats.send_quality = static_cast<std::uint32_t>(level.jpeg_quality);
  stats.send_scale = level.scale;
  stats.send_density = static_cast<std::uint32_t>(level.density);
  stats.link_bytes_per_s = e.known ? e.delivery_bytes_per_s : 0.0;
  stats.link_rtt_ms = e.rtt_s * 1e3;
  const double wait = SendController::backlog_wait_s(e, backlog_bytes_());
  stats.backlog_s = std::isfinite(wait) ? wait : -1.0;
}

}  // namespace keyfleet::agent
