#include "keyfleet/agent/bandwidth_ledger.hpp"

#include <cmath>
#include <stdexcept>

namespace keyfleet::agent {

BandwidthLedger::BandwidthLedger(int baseline_sample_every) : sample_every_(baseline_sample_every) {
  if (sample_every_ < 1) throw std::invalid_argument("baseline_sample_every must be >= 1");
}

bool BandwidthLedger::should_sample_frame(std::uint64_t frame_number) const {
  return frame_number % static_cast<std::uint64_t>(sample_every_) == 0;
}

std::uint64_t BandwidthLedger::Baseline::total() const {
  if (sampled == 0) return 0;
  if (sampled == events) return sampled_bytes;
  const double mean = static_cast<double>(sampled_bytes) / static_cast<double>(sampled);
  return static_cast<std::uint64_t>(std::llround(mean * static_cast<double>(events)));
}

void BandwidthLedger::record_frame(std::optional<std::uint64_t> sampled_sample_bytes) {
  ++stream_all_.events;
  if (sampled_sample_bytes) {
    ++stream_all_.sampled;
    stream_all_.sampled_bytes += *sampled_sample_bytes;
  }
}

void BandwidthLedger::record_vslam_keyframe(std::optional<std::uint64_t> sample_bytes) {
  ++vslam_.events;
  if (sample_bytes) {
    ++vslam_.sampled;
    vslam_.sampled_bytes += *sample_bytes;
  }
}

void BandwidthLedger::record_sent(std::uint64_t sample_bytes) {
  ++keyframes_sent_;
  bytes_sent_ += sample_bytes;
}

void BandwidthLedger::record_resent(std::uint64_t sample_bytes) {
  ++keyframes_resent_;
  bytes_resent_ += sample_bytes;
}

void BandwidthLedger::record_dropped(std::uint64_t keyframes) { keyframes_dropped_ += keyframes; }

void BandwidthLedger::fill(AgentStats& stats) const {
  stats.frames_seen = stream_all_.events;
  stats.vslam_keyframes = vslam_.events;
  stats.keyframes_sent = keyframes_sent_;
  stats.keyframes_resent = keyframes_resent_;
  stats.keyframes_dropped = keyframes_dropped_;
  stats.bytes_sent = bytes_sent_;
  stats.bytes_resent = bytes_resent_;
  stats.stream_all_bytes = stream_all_.total();
  stats.stream_all_estimated = stream_all_.estimated();
  stats.stream_all_sampled_frames = stream_all_.sampled;
  stats.vslam_keyframe_bytes = vslam_.total();
  stats.vslam_keyframe_estimated = vslam_.estimated();
}

}  // namespace keyfleet::agent
