#pragma once
#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/keyframe_agent.hpp"
#include "keyfleet/common/shutdown_signal.hpp"

namespace keyfleet::agent {

enum class AgentOutcome {
  kDelivered,    // every keyframe acknowledged by a station
  kUndelivered,  // drain timed out: keyframes remain in the outbox file
  kStopped,      // stopped by a signal; the outbox keeps what was not acknowledged
};

// Drives a KeyframeAgent from a FrameSource in real time (or as fast as possible),
// waiting on the stop token instead of sleeping, then drains the outbox.
class AgentRunner {
 public:
  AgentRunner(const AgentConfig& config, FrameSource& source, KeyframeAgent& agent, AgentLink& link,
              StageClock& clock, Logger logger);
  AgentOutcome run(const StopToken& stop);

 private:
  bool wait_for_station(const StopToken& stop);
  void stream(const StopToken& stop);
  AgentOutcome drain(const StopToken& stop);
  void tick(std::int64_t now_ns, std::chrono::milliseconds ack_wait);

  AgentConfig config_;
  FrameSource& source_;
  KeyframeAgent& agent_;
  AgentLink& link_;
  StageClock& clock_;
  Logger logger_;
  std::chrono::steady_clock::time_point next_stats_;
};

}  // namespace keyfleet::agent
