#pragma once
#include <chrono>
#include <deque>
#include <memory>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "keyfleet/agent/bandwidth_ledger.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/agent/keyframe_value.hpp"
#include "keyfleet/agent/link_aware_sender.hpp"
#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/agent/stage_clock.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/transport.hpp"

namespace keyfleet::agent {

// The agent's pipeline as synchronous steps, with no threads and no clocks of its own:
// process() takes one frame through selection, encoding (at the level the link affords), the
// outbox and the link; service() handles acknowledgements, sends what waits (by value, then
// age), and applies the outbox bounds. A new keyframe goes at once when the link takes it.
class KeyframeAgent {
 public:
  KeyframeAgent(const AgentConfig& config, std::unique_ptr<KeyframeSelector> selector,
                std::unique_ptr<ImageCodec> codec, Outbox& outbox, AgentLink& link,
                StageClock& clock, Logger logger);

  // now_ns of process, finish_stream and service: the outbox's clock (boot_time_ns()); of
  // publish_stats and stats: the wall clock, which the station's reports are on.
  void process(const Frame& frame, std::int64_t now_ns);
  void finish_stream(std::int64_t now_ns);
  // Takes acknowledgements (waiting up to ack_wait for the first), resends what is due
  // while a station is matched, evicts what the outbox bounds give up on: the count always,
  // the age (max_age_s) only once a station has been matched that long without a break, so
  // an outage of any length loses nothing the count bound keeps.
  void service(std::int64_t now_ns, std::chrono::milliseconds ack_wait);
  void publish_stats(bool finished, std::int64_t now_ns);

  AgentStats stats(bool finished, std::int64_t now_ns) const;
  std::uint64_t pending() const { return outbox_.pending(); }
  std::uint64_t rejected() const { return rejected_; }

 private:
  void publish_selection(const Selection& selection, std::int64_t now_ns);
  void observe_link(std::int64_t now_ns);
  Keyframe make_keyframe(const Frame& frame, std::vector<std::uint8_t> image) const;
  // The frame's JPEG: encoded once, whether for a baseline measurement or for publication;
  // `whole` is the frame's whole image (whole_image), only read when not encoded yet.
  const std::vector<std::uint8_t>& encoded(const Frame& frame, const cv::Mat& whole);
  // Every pixel of the frame (decoded again where the source decoded less); the reduced image,
  // logged as an error, in the unexpected case that this decode fails.
  cv::Mat whole_image(const Frame& frame) const;

  AgentConfig config_;
  std::unique_ptr<KeyframeSelector> selector_;
  std::unique_ptr<ImageCodec> codec_;
  Outbox& outbox_;
  AgentLink& link_;
  StageClock& clock_;
  Logger logger_;
  BandwidthLedger ledger_;
  LinkAwareSender sender_;
  KeyframeValue value_;
  std::uint64_t rejected_ = 0;
  std::set<std::uint64_t> never_sent_;  // in the outbox, first write failed
  std::int64_t last_now_ns_ = 0;        // the outbox clock's latest time (stats read the link then)
  std::optional<std::int64_t> matched_since_ns_;  // a station matched since, without a break
  // Encodings of recent frames, oldest first; none older than a selection window can reach.
  std::deque<std::pair<std::uint64_t, std::vector<std::uint8_t>>> encodings_;
};

}  // namespace keyfleet::agent
