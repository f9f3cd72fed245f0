#pragma once
#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/keyframe_agent.hpp"
#include "keyfleet/common/shutdown_signal.hpp"

#include <string>
#include <vector>

namespace keyfleet::agent {

enum class AgentOutcome {
  kDelivered,    // every keyframe acknowledged by a station
  kUndelivered,  // drain timed out: keyframes remain in the outbox file
  kStopped,      // stopped by a signal; the outbox keeps what was not acknowledged
};

// How the replay kept to its schedule (realtime sources): a frame is late when it is taken from
// the source more than one frame period after its due time (start + index / fps).
struct StreamSummary {
  std::uint64_t frames = 0;
  double fps = 0;
  double stream_s = 0;  // wall time from the first frame to the end of the last one
  std::uint64_t late_frames = 0;
  double max_lag_ms = 0;  // the most a frame was taken after its due time
  // The process's CPU (all threads: the pipeline, DDS, the outbox) over the same span: without
  // the start (model loading, the DDS-Security handshake) and the drain, which a long flight
  // amortises away.
  double stream_cpu_s = 0;
  double flight_s() const { return fps > 0 ? double(frames) / fps : 0; }
};

// Writes the summary, the stages' CPU (ms and calls) and the process's CPU seconds as JSON
// (`keyfleet bench fleet` reads it from each agent's run folder). Returns false when the file
// cannot be written.
bool write_stream_summary(const std::string& path, const StreamSummary& summary,
                          const std::vector<StageTime>& stages, double process_cpu_s);

// Drives a KeyframeAgent from a FrameSource in real time (or as fast as possible),
// waiting on the stop token instead of sleeping, then drains the outbox.
class AgentRunner {
 public:
  AgentRunner(const AgentConfig& config, FrameSource& source, KeyframeAgent& agent, AgentLink& link,
              StageClock& clock, Logger logger);
  AgentOutcome run(const StopToken& stop);
  const StreamSummary& summary() const { return summary_; }

 private:
  bool wait_for_station(const StopToken& stop);
  void stream(const StopToken& stop);
  AgentOutcome drain(const StopToken& stop);
  // Services the outbox (on boot_time_ns()) and publishes stats when due (on the wall clock).
  void tick(std::chrono::milliseconds ack_wait);

  AgentConfig config_;
  FrameSource& source_;
  KeyframeAgent& agent_;
  AgentLink& link_;
  StageClock& clock_;
  Logger logger_;
  std::chrono::steady_clock::time_point next_stats_;
  StreamSummary summary_;
};

}  // namespace keyfleet::agent
