#include "keyfleet/agent/agent_runner.hpp"

#include "keyfleet/common/clock.hpp"

#include <algorithm>
#include <fstream>

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

void AgentRunner::tick(milliseconds ack_wait) {
  agent_.service(boot_time_ns(), ack_wait);
  if (Clock::now() >= next_stats_) {
    agent_.publish_stats(false, wall_time_ns());
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
  const double cpu_start = process_cpu_s();  // the process's, all threads
  const double fps = source_.fps();
  summary_ = StreamSummary{};
  summary_.fps = fps;
  std::uint64_t& frames = summary_.frames;
  while (!stop.requested()) {
    std::optional<Frame> frame;
    {
      auto scope = clock_.measure("source");
      frame = source_.next();
    }
    if (!frame) break;
    if (config_.source.realtime) {
      const double lag_ms =
          std::chrono::duration<double, std::milli>(Clock::now() - start).count() -
          1e3 * static_cast<double>(frames) / fps;
      summary_.max_lag_ms = std::max(summary_.max_lag_ms, lag_ms);
      if (lag_ms > 1e3 / fps) ++summary_.late_frames;
    }
    agent_.process(*frame, boot_time_ns());
    ++frames;
    if (config_.source.realtime) {
      // Serve acknowledgements while waiting for the next frame's time, in waits of whole
      // milliseconds rounded up: a remainder under one would be a wait of none, and the loop
      // would spin on it (about 30 passes a frame, 0.3 ms of a frame's CPU at 30 frames/s).
      const auto due = start + seconds(static_cast<double>(frames) / fps);
      do {
        const auto left = std::chrono::ceil<milliseconds>(due - Clock::now());
        tick(std::max(milliseconds(0), std::min(left, milliseconds(50))));
      } while (Clock::now() < due && !stop.requested());
    } else {
      tick(milliseconds(0));
    }
  }
  agent_.finish_stream(boot_time_ns());
  summary_.stream_s = std::chrono::duration<double>(Clock::now() - start).count();
  summary_.stream_cpu_s = process_cpu_s() - cpu_start;
  logger_->info("stream ended after {} frames in {:.2f} s ({:.2f} s of flight), {} late", frames,
                summary_.stream_s, summary_.flight_s(), summary_.late_frames);
}

AgentOutcome AgentRunner::drain(const StopToken& stop) {
  const auto deadline = Clock::now() + seconds(config_.drain_timeout_s);
  while (agent_.pending() > 0 && Clock::now() < deadline && !stop.requested())
    tick(milliseconds(50));
  const auto pending = agent_.pending();
  if (config_.linger_s > 0 && pending == 0 && !stop.requested()) {
    logger_->info("drained; lingering {:g} s with nothing to send", config_.linger_s);
    const auto linger_end = Clock::now() + seconds(config_.linger_s);
    while (Clock::now() < linger_end && !stop.requested()) tick(milliseconds(50));
    logger_->info("lingering done");
  }
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

bool write_stream_summary(const std::string& path, const StreamSummary& summary,
                          const std::vector<StageTime>& stages, double process_cpu_s) {
  std::ofstream out(path);
  out << "{\"frames\": " << summary.frames << ", \"fps\": " << summary.fps
      << ", \"stream_s\": " << summary.stream_s << ", \"late_frames\": " << summary.late_frames
      << ", \"max_lag_ms\": " << summary.max_lag_ms << ", \"process_cpu_s\": " << process_cpu_s
      << ", \"stream_cpu_s\": " << summary.stream_cpu_s << ", \"stages\": {";
  for (std::size_t i = 0; i < stages.size(); ++i)
    out << (i ? ", " : "") << "\"" << stages[i].stage
        << "\": {\"cpu_ms\": " << stages[i].cpu_ms_total << ", \"calls\": " << stages[i].calls
        << "}";
  out << "}}\n";
  return bool(out);
}

}  // namespace keyfleet::agent
