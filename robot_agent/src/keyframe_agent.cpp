#include "keyfleet/agent/keyframe_agent.hpp"

namespace keyfleet::agent {

KeyframeAgent::KeyframeAgent(const AgentConfig& config, std::unique_ptr<KeyframeSelector> selector,
                             std::unique_ptr<ImageCodec> codec, Outbox& outbox, AgentLink& link,
                             StageClock& clock, Logger logger)
    : config_(config),
      selector_(std::move(selector)),
      codec_(std::move(codec)),
      outbox_(outbox),
      link_(link),
      clock_(clock),
      logger_(std::move(logger)),
      ledger_(config.ledger.baseline_sample_every),
      sender_(
          config.link_adaptation, *codec_, config.codec.jpeg_quality,
          link_prior_bytes_per_s(config.dds.link), [this] { return outbox_.pending_bytes(); },
          logger_) {}

Keyframe KeyframeAgent::make_keyframe(const Frame& frame, std::vector<std::uint8_t> image) const {
  Keyframe keyframe;
  keyframe.robot_id = config_.robot_id;
  keyframe.frame_index = frame.index;
  keyframe.capture_time_ns = frame.capture_time_ns;
  keyframe.encoding = codec_->encoding();
  const cv::Size size = frame_size(frame);
  keyframe.width = static_cast<std::uint32_t>(size.width);
  keyframe.height = static_cast<std::uint32_t>(size.height);
  keyframe.image = std::move(image);
  keyframe.camera_pose = frame.pose;
  return keyframe;
}

cv::Mat KeyframeAgent::whole_image(const Frame& frame) const {
  cv::Mat whole = full_image(frame);
  if (whole.empty()) {
    logger_->error("frame {}: its file no longer decodes whole; its keyframe goes at {}x{}",
                   frame.index, frame.image.cols, frame.image.rows);
    return frame.image;
  }
  return whole;
}

const std::vector<std::uint8_t>& KeyframeAgent::encoded(const Frame& frame, const cv::Mat& whole) {
  for (const auto& [index, bytes] : encodings_)
    if (index == frame.index) return bytes;
  const std::uint64_t reach = std::uint64_t(config_.selector.max_window_frames);
  while (!encodings_.empty() && encodings_.front().first + reach < frame.index)
    encodings_.pop_front();
  encodings_.emplace_back(frame.index, codec_->encode(whole));
  return encodings_.back().second;
}

void KeyframeAgent::observe_link(std::int64_t now_ns) {
  const bool matched = link_.matched_stations() > 0;
  if (!matched)
    matched_since_ns_.reset();
  else if (!matched_since_ns_)
    matched_since_ns_ = now_ns;
  sender_.station_matched(matched, now_ns);
}

void KeyframeAgent::process(const Frame& frame, std::int64_t now_ns) {
  last_now_ns_ = now_ns;
  observe_link(now_ns);
  const SelectorStep step = selector_->push(frame);  // measures its own stages
  // Baselines: what this frame would cost as a sample, measured on the frames sampled
  // for the stream-all baseline and on every V-SLAM keyframe.
  std::optional<std::uint64_t> frame_bytes;
  if (ledger_.should_sample_frame(frame.index) || step.vslam_keyframe) {
    auto scope = clock_.measure("baseline");
    frame_bytes = link_.serialized_size(make_keyframe(frame, encoded(frame, whole_image(frame))));
  }
  ledger_.record_frame(ledger_.should_sample_frame(frame.index) ? frame_bytes : std::nullopt);
  if (step.vslam_keyframe) ledger_.record_vslam_keyframe(frame_bytes);

  for (const auto& selection : step.selected) publish_selection(selection, now_ns);
}

void KeyframeAgent::finish_stream(std::int64_t now_ns) {
  for (const auto& selection : selector_->finish()) publish_selection(selection, now_ns);
}

void KeyframeAgent::publish_selection(const Selection& selection, std::int64_t now_ns) {
  Keyframe keyframe;
  LinkAwareSender::Encoded at_level;
  {
    auto scope = clock_.measure("encode");
    const cv::Mat whole = whole_image(selection.frame);
    at_level = sender_.encode(
        whole, selection.text_regions, now_ns,
        [&]() -> const std::vector<std::uint8_t>& { return encoded(selection.frame, whole); });
    keyframe = make_keyframe(selection.frame, std::move(at_level.image));
    keyframe.width = at_level.width;
    keyframe.height = at_level.height;
  }
  keyframe.sequence_number = outbox_.next_sequence();
  keyframe.vslam_keyframe_index = selection.vslam_keyframe_index;
  keyframe.window_first_frame = selection.window_first_frame;
  keyframe.window_last_frame = selection.window_last_frame;
  keyframe.quality_score = selection.quality_score;
  keyframe.sharpness_score = selection.sharpness_score;
  keyframe.semantic_score = selection.semantic_score;
  keyframe.text_regions = std::move(at_level.text_regions);

  auto scope = clock_.measure("publish");
  const double value =
      value_(selection.semantic_score, selection.quality_score, selection.frame.pose);
  outbox_.add(keyframe, now_ns, value, at_level.held);  // durable before it is on the wire
  if (at_level.held) {
    never_sent_.insert(keyframe.sequence_number);
    logger_->debug("keyframe {} (frame {}) held back by the link's density",
                   keyframe.sequence_number, keyframe.frame_index);
    return;
  }
  const PublishResult result = link_.publish(keyframe);
  if (!result.ok) {
    logger_->warn("keyframe {} not sent now ({}); it stays in the outbox for a resend",
                  keyframe.sequence_number, result.error);
    never_sent_.insert(keyframe.sequence_number);
    return;
  }
  ledger_.record_sent(result.serialized_bytes);
  sender_.on_sent(keyframe.sequence_number, result.serialized_bytes, now_ns);
  outbox_.mark_sent(keyframe.sequence_number, now_ns);
  logger_->debug("keyframe {} (frame {}) sent, {} bytes", keyframe.sequence_number,
                 keyframe.frame_index, result.serialized_bytes);
}

void KeyframeAgent::service(std::int64_t now_ns, std::chrono::milliseconds ack_wait) {
  auto scope = clock_.measure("service");
  last_now_ns_ = now_ns;
  for (const auto& ack : link_.take_acks(config_.robot_id, ack_wait)) {
    if (ack.status == AckStatus::kConflict) {
      // The station holds this number with another image: ours goes again under a new one.
      if (const auto renumbered = outbox_.renumber(ack.sequence_number)) {
        never_sent_.erase(ack.sequence_number);
        sender_.forget(ack.sequence_number, now_ns);
        logger_->error("station holds sequence {} with another image: sending ours as {}",
                       ack.sequence_number, *renumbered);
      }
      continue;
    }
    sender_.on_acked(ack.sequence_number, now_ns);
    const bool was_pending = outbox_.acknowledge(ack.sequence_number);
    if (ack.status == AckStatus::kRejected && was_pending) {
      ++rejected_;
      logger_->error("station rejected keyframe {}: {}", ack.sequence_number, ack.reason);
    }
  }
  // The bounds first: a keyframe they give up on is not sent once more on its way out.
  observe_link(now_ns);
  const bool by_age =
      matched_since_ns_ &&
      now_ns - *matched_since_ns_ > static_cast<std::int64_t>(config_.outbox.max_age_s * 1e9);
  const auto evicted = outbox_.evict(now_ns, by_age);
  if (!evicted.empty()) {
    for (const auto sequence : evicted) {
      never_sent_.erase(sequence);
      sender_.forget(sequence, now_ns);
    }
    ledger_.record_dropped(evicted.size());
    logger_->error(
        "outbox bounds reached: gave up on {} unacknowledged keyframe(s) {}..{} "
        "(max_pending {}, max_age_s {})",
        evicted.size(), evicted.front(), evicted.back(), config_.outbox.max_pending,
        config_.outbox.max_age_s);
  }
  sender_.update(now_ns);
  if (link_.matched_stations() > 0) {
    const auto due = outbox_.due_for_resend(
        now_ns, static_cast<std::size_t>(config_.outbox.resend_batch), sender_.room_for_held());
    std::size_t written = 0;
    for (const auto& keyframe : due) {
      const PublishResult result = link_.publish(keyframe);
      if (!result.ok) break;  // the writer is busy: try again on the next pass
      if (never_sent_.erase(keyframe.sequence_number) > 0) {
        ledger_.record_sent(result.serialized_bytes);
        sender_.on_sent(keyframe.sequence_number, result.serialized_bytes, now_ns);
      } else {
        ledger_.record_resent(result.serialized_bytes);
        sender_.on_resent(keyframe.sequence_number);
      }
      outbox_.mark_sent(keyframe.sequence_number, now_ns);
      ++written;
    }
    if (written > 0)
      logger_->info("sent {} of {} unacknowledged keyframe(s) due from {}", written, due.size(),
                    due.front().sequence_number);
  }
}

AgentStats KeyframeAgent::stats(bool finished, std::int64_t now_ns) const {
  AgentStats stats;
  stats.robot_id = config_.robot_id;
  stats.report_time_ns = now_ns;
  stats.finished = finished;
  ledger_.fill(stats);
  stats.keyframes_pending = outbox_.pending();
  sender_.fill(stats, last_now_ns_);
  stats.stages = clock_.snapshot();
  return stats;
}

void KeyframeAgent::publish_stats(bool finished, std::int64_t now_ns) {
  const PublishResult result = link_.publish(stats(finished, now_ns));
  if (!result.ok) logger_->warn("agent stats not sent: {}", result.error);
}

}  // namespace keyfleet::agent
