#include "keyfleet/agent/agent_runner.hpp"

#include "keyfleet/common/clock.hpp"

namespace keyfleet::agent {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

AgentRunner::AgentRunner(const AgentConfig& config, FrameSource& source, KeyframeAgent& agent,
                         AgentLink& link, StageClock& clock, Logger logger)
    : config_(config),
      source_(source),
      agent_(agent),
      link_(link),
      clock_(clock),
      logger_(std::move(logger)) {}

void AgentRunner::tick(std::int64_t now_ns, milliseconds ack_wait) {
  agent_.service(now_ns, ack_wait);
  if (Clock::now() >= next_stats_) {
    agent_.publish_stats(false, now_ns);
    next_stats_ = Clock::now() + seconds(config_.stats_period_s);
  }
}

bool AgentRunner::wait_for_station(const StopToken& stop) {
  const auto deadline = Clock::now() + seconds(config_.wait_for_station_s);
  while (link_.matched_stations() == 0 && Clock::now() < deadline) {
    if (stop.wait_for(milliseconds(20))) return false;
  }
  if (link_.matched_stations() == 0)
    logger_->warn("no station after {} s; streaming anyway, keyframes wait in the outbox",
                  config_.wait_for_station_s);
  else
    logger_->info("station matched");
  return true;
}

void AgentRunner::stream(const StopToken& stop) {
  const auto start = Clock::now();
  const double fps = source_.fps();
  std::uint64_t frames = 0;
  while (!stop.requested()) {
    std::optional<Frame> frame;
    {
      auto scope = clock_.measure("source");
      frame = source_.next();
    }
    if (!frame) break;
    agent_.process(*frame, wall_time_ns());
    ++frames;
    if (config_.source.realtime) {
      // Serve acknowledgements while waiting for the next frame's time.
      const auto due = start + seconds(static_cast<double>(frames) / fps);
      do {
        const auto left = std::chrono::duration_cast<milliseconds>(due - Clock::now());
        tick(wall_time_ns(), std::max(milliseconds(0), std::min(left, milliseconds(50))));
      } while (Clock::now() < due && !stop.requested());
    } else {
      tick(wall_time_ns(), milliseconds(0));
    }
  }
  agent_.finish_stream(wall_time_ns());
  logger_->info("stream ended after {} frames", frames);
}

AgentOutcome AgentRunner::drain(const StopToken& stop) {
  const auto deadline = Clock::now() + seconds(config_.drain_timeout_s);
  while (agent_.pending() > 0 && Clock::now() < deadline && !stop.requested())
    tick(wall_time_ns(), milliseconds(50));
  const auto pending = agent_.pending();
  agent_.publish_stats(!stop.requested(), wall_time_ns());
  if (!link_.flush_stats(milliseconds(3000)) && link_.matched_stations() > 0)
    logger_->warn("final stats not acknowledged by the station within 3 s");
  if (stop.requested()) return AgentOutcome::kStopped;
  if (pending > 0) return AgentOutcome::kUndelivered;
  return AgentOutcome::kDelivered;
}

AgentOutcome AgentRunner::run(const StopToken& stop) {
  logger_->info("streaming from {}", source_.describe());
  next_stats_ = Clock::now();
  if (!wait_for_station(stop)) return drain(stop);
  stream(stop);
  const auto outcome = drain(stop);
  const AgentStats s = agent_.stats(true, wall_time_ns());
  logger_->info(
      "done: {} frames, {} keyframes sent ({} bytes, {} resent), {} pending, {} dropped, "
      "{} rejected",
      s.frames_seen, s.keyframes_sent, s.bytes_sent, s.keyframes_resent, s.keyframes_pending,
      s.keyframes_dropped, agent_.rejected());
  return outcome;
}

}  // namespace keyfleet::agent
