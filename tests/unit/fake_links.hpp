#pragma once
// In-memory test doubles for the transport seam: no DDS, no threads, no waiting.
#include <chrono>
#include <cstdint>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/common/transport.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::test {

// Hands out queued inboxes one per take() and records every acknowledgement.
class FakeStationLink : public StationLink {
 public:
  void queue(StationInbox inbox) { inboxes_.push_back(std::move(inbox)); }

  StationInbox take(std::chrono::milliseconds wait, std::size_t max_keyframes) override {
    last_wait = wait;
    last_max_keyframes = max_keyframes;
    if (inboxes_.empty()) return {};
    StationInbox inbox = std::move(inboxes_.front());
    inboxes_.pop_front();
    return inbox;
  }

  PublishResult acknowledge(const KeyframeAck& ack) override {
    acks.push_back(ack);
    PublishResult result;
    result.ok = acknowledge_ok;
    result.serialized_bytes = acknowledge_ok ? 64 : 0;
    if (!acknowledge_ok) result.error = "writer busy";
    return result;
  }

  std::size_t matched_agents() const override { return 1; }

  std::vector<KeyframeAck> acks;
  bool acknowledge_ok = true;
  std::chrono::milliseconds last_wait{-1};
  std::size_t last_max_keyframes = 0;

 private:
  std::deque<StationInbox> inboxes_;
};

// Records what the agent publishes, refuses writes on demand and hands out queued
// acknowledgements. A keyframe's serialized size is its image bytes plus a fixed overhead.
class FakeAgentLink : public AgentLink {
 public:
  static constexpr std::uint64_t kKeyframeOverhead = 200;
  static constexpr std::uint64_t kStatsBytes = 300;

  PublishResult publish(const Keyframe& keyframe) override {
    ++keyframe_attempts;
    if (refuse()) return refused();
    keyframes.push_back(keyframe);
    return accepted(serialized_size(keyframe));
  }

  PublishResult publish(const AgentStats& agent_stats) override {
    if (refuse()) return refused();
    stats.push_back(agent_stats);
    return accepted(kStatsBytes);
  }

  std::uint64_t serialized_size(const Keyframe& keyframe) const override {
    return keyframe.image.size() + kKeyframeOverhead;
  }

  std::size_t matched_stations() const override { return matched; }

  // Only the acknowledgements for `robot_id`; the others stay queued.
  std::vector<KeyframeAck> take_acks(const std::string& robot_id,
                                     std::chrono::milliseconds wait) override {
    ack_requests.push_back(robot_id);
    last_ack_wait = wait;
    std::vector<KeyframeAck> taken;
    std::deque<KeyframeAck> kept;
    for (auto& ack : acks_) {
      if (ack.robot_id == robot_id)
        taken.push_back(std::move(ack));
      else
        kept.push_back(std::move(ack));
    }
    acks_ = std::move(kept);
    return taken;
  }

  bool flush_stats(std::chrono::milliseconds /*timeout*/) override { return true; }

  void queue_ack(const std::string& robot_id, std::uint64_t sequence, AckStatus status,
                 const std::string& reason = "") {
    acks_.push_back(KeyframeAck{robot_id, sequence, status, reason});
  }
  std::size_t queued_acks() const { return acks_.size(); }

  std::vector<Keyframe> keyframes;  // accepted keyframe writes, in order
  std::vector<AgentStats> stats;    // accepted stats writes, in order
  std::size_t keyframe_attempts = 0;
  std::size_t matched = 1;
  int refuse_next = 0;             // refuse this many of the next writes (keyframes or stats)...
  int accept_before_refusing = 0;  // ...after letting this many through
  bool refuse_all = false;
  std::vector<std::string> ack_requests;  // robot ids take_acks was asked for
  std::chrono::milliseconds last_ack_wait{-1};

 private:
  bool refuse() {
    if (refuse_all) return true;
    if (refuse_next <= 0) return false;
    if (accept_before_refusing > 0) {
      --accept_before_refusing;
      return false;
    }
    --refuse_next;
    return true;
  }
  static PublishResult refused() {
    PublishResult result;
    result.error = "writer busy";
    return result;
  }
  static PublishResult accepted(std::uint64_t bytes) {
    PublishResult result;
    result.ok = true;
    result.serialized_bytes = bytes;
    return result;
  }

  std::deque<KeyframeAck> acks_;
};

}  // namespace keyfleet::test
