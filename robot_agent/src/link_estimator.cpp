#include "keyfleet/agent/link_estimator.hpp"

#include <algorithm>

namespace keyfleet::agent {
namespace {

constexpr std::size_t kRttSamples = 16;
constexpr double kRttGain = 0.125;  // the smoothed round trip moves an eighth towards a sample

double seconds_between(std::int64_t from_ns, std::int64_t to_ns) {
  return to_ns > from_ns ? static_cast<double>(to_ns - from_ns) * 1e-9 : 0.0;
}

}  // namespace

LinkEstimator::LinkEstimator(double window_s, double min_busy_s, double max_age_s)
    : window_s_(window_s), min_busy_s_(min_busy_s), max_age_s_(max_age_s) {}

void LinkEstimator::close_segment(std::int64_t now_ns, std::uint64_t acked) {
  Segment segment;
  segment.end_ns = now_ns;
  segment.busy_s = busy() ? seconds_between(segment_start_ns_, now_ns) : 0.0;
  segment.acked_bytes = acked;
  segment_start_ns_ = std::max(segment_start_ns_, now_ns);
  if (segment.busy_s == 0 && acked == 0) return;
  segments_.push_back(segment);
  segments_busy_s_ += segment.busy_s;
  // Keep the newest window_s of busy time (always the newest segment).
  while (segments_.size() > 1 && segments_busy_s_ - segments_.front().busy_s >= window_s_) {
    segments_busy_s_ -= segments_.front().busy_s;
    segments_.pop_front();
  }
}

void LinkEstimator::on_sent(std::uint64_t sequence, std::uint64_t bytes, std::int64_t now_ns) {
  if (flights_.count(sequence) > 0) return;
  close_segment(now_ns, 0);
  flights_[sequence] = Flight{bytes, now_ns, false};
  in_flight_bytes_ += bytes;
}

void LinkEstimator::on_resent(std::uint64_t sequence) {
  if (auto it = flights_.find(sequence); it != flights_.end()) it->second.resent = true;
}

void LinkEstimator::on_acked(std::uint64_t sequence, std::int64_t now_ns) {
  const auto it = flights_.find(sequence);
  if (it == flights_.end()) return;
  close_segment(now_ns, it->second.bytes);
  if (!it->second.resent && now_ns > it->second.sent_ns) {
    const double rtt = seconds_between(it->second.sent_ns, now_ns);
    srtt_s_ = srtt_s_ == 0 ? rtt : srtt_s_ + kRttGain * (rtt - srtt_s_);
    recent_rtts_.push_back(rtt);
    if (recent_rtts_.size() > kRttSamples) recent_rtts_.pop_front();
  }
  in_flight_bytes_ -= it->second.bytes;
  flights_.erase(it);
}

void LinkEstimator::forget(std::uint64_t sequence, std::int64_t now_ns) {
  const auto it = flights_.find(sequence);
  if (it == flights_.end()) return;
  close_segment(now_ns, 0);
  in_flight_bytes_ -= it->second.bytes;
  flights_.erase(it);
}

void LinkEstimator::pause(std::int64_t now_ns) {
  if (paused_) return;
  close_segment(now_ns, 0);
  paused_ = true;
}

void LinkEstimator::resume(std::int64_t now_ns) {
  if (!paused_) return;
  close_segment(now_ns, 0);
  paused_ = false;
  // What was in flight when the station went away is sent again after the outage: its
  // round trip would measure the outage.
  for (auto& [sequence, flight] : flights_) flight.resent = true;
}

LinkEstimate LinkEstimator::estimate(std::int64_t now_ns) const {
  LinkEstimate e;
  // The open stretch first (busy without an acknowledgement so far), then the newest segments
  // until the window is full: a silence as long as the window leaves no old delivery behind.
  double busy_s = busy() ? seconds_between(segment_start_ns_, now_ns) : 0.0;
  std::uint64_t acked = 0;
  for (auto it = segments_.rbegin(); it != segments_.rend() && busy_s < window_s_; ++it) {
    if (seconds_between(it->end_ns, now_ns) > max_age_s_) break;
    busy_s += it->busy_s;
    acked += it->acked_bytes;
  }
  e.busy_s = busy_s;
  // Known once something was delivered over min_busy_s, or when a whole window went by busy
  // without a delivery (a stalled link, rate 0).
  e.known = (acked > 0 && busy_s >= min_busy_s_) || busy_s >= window_s_;
  if (busy_s > 0) e.delivery_bytes_per_s = static_cast<double>(acked) / busy_s;
  if (!e.known && prior_bytes_per_s_ > 0) {
    e.delivery_bytes_per_s = prior_bytes_per_s_;
    e.known = true;
    e.from_prior = true;
  }
  e.rtt_s = srtt_s_;
  if (!recent_rtts_.empty())
    e.min_rtt_s = *std::min_element(recent_rtts_.begin(), recent_rtts_.end());
  return e;
}

}  // namespace keyfleet::agent
