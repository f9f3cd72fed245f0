#pragma once
// Per-robot delivery figures of one mission, computed from the station's database (and,
// where a shaped link measured them, the bytes on the wire). Pure functions on plain
// records, so the arithmetic is testable on hand-made cases.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace keyfleet::mission {

// One stored keyframe (first copy) as the station recorded it.
struct DeliveredKeyframe {
  std::string robot_id;
  std::int64_t capture_time_ns = 0;    // agent clock (the same machine clock here)
  std::int64_t received_ns = 0;        // station clock
  std::uint64_t serialized_bytes = 0;  // serialized DDS sample
  std::int64_t sequence_number = -1;   // the robot's; -1 where not known
};

// The agent's last stats sample as the station stored it.
using AgentTotals = AgentStats;

// Counters of the drone's end of a shaped link (veth statistics), when there was one.
struct WireBytes {
  std::uint64_t tx_bytes = 0;  // drone -> station
  std::uint64_t rx_bytes = 0;  // station -> drone (acks, DDS control traffic)
};

struct StationRecords {
  std::vector<DeliveredKeyframe> keyframes;  // ordered by robot, then received_ns
  std::map<std::string, AgentTotals> agents;
};

struct RobotMetrics {
  std::string robot_id;
  std::uint64_t delivered = 0;
  double latency_median_ms = 0;  // received_ns - capture_time_ns
  double latency_p95_ms = 0;
  std::uint64_t dropped = 0;  // outbox evictions
  // Link adaptation (agent stats): keyframes sent below the richest level, selections held back
  // by density, level changes.
  std::uint64_t reduced = 0;
  std::uint64_t thinned = 0;
  std::uint64_t level_changes = 0;
  std::uint64_t resent = 0;
  std::uint64_t refused_writes = 0;  // writes the capped writer refused (from the agent log)
  std::uint64_t payload_bytes = 0;   // serialized samples stored (first copies)
  std::uint64_t sent_bytes = 0;      // serialized samples the agent handed to DDS, resends included
  std::optional<WireBytes> wire;     // nullopt: not measured
  double throughput_bytes_per_s = 0;  // payload over the span of received_ns
  std::uint64_t stream_all_bytes = 0;
  bool stream_all_estimated = true;
  std::uint64_t vslam_keyframe_bytes = 0;
  bool vslam_keyframe_estimated = true;
  double saving_vs_stream_all = 0;  // baseline bytes / payload bytes (0 when nothing arrived)
  double saving_vs_vslam = 0;
  bool agent_stats_seen = false;
};

// Linear interpolation between closest ranks (numpy's default); 0 for no values.
double percentile(std::vector<double> values, double p);
double median(std::vector<double> values);

// Bytes received in each `bin_ns` interval from `origin_ns` (bin 0 starts at origin);
// keyframes before the origin go to bin 0. Length: up to the last keyframe's bin.
std::vector<std::uint64_t> bytes_per_bin(const std::vector<DeliveredKeyframe>& keyframes,
                                         std::int64_t origin_ns, std::int64_t bin_ns);

// Bytes after the first keyframe over the time from the first to the last receipt: the
// first sample's bytes arrived before the span began. 0 with fewer than two keyframes.
double throughput_bytes_per_s(const std::vector<DeliveredKeyframe>& keyframes);

// baseline / sent, 0 when nothing was sent.
double saving_ratio(std::uint64_t baseline_bytes, std::uint64_t sent_bytes);

// `capture_origin_ns`: the wall-clock time of capture_time_ns 0. Generated and scenario
// sources stamp frames from the start of the stream, so latency needs the stream's start
// (0 when capture times are already wall-clock times).
RobotMetrics robot_metrics(const std::string& robot_id,
                           const std::vector<DeliveredKeyframe>& keyframes,
                           const std::optional<AgentTotals>& totals,
                           const std::optional<WireBytes>& wire,
                           std::int64_t capture_origin_ns = 0);

// Reads a station database after the mission. Throws StartupError naming the file.
StationRecords read_station_records(const std::string& database_path);

// The wall-clock time an agent began streaming (its "station matched" or "streaming
// anyway" log line, local time, millisecond resolution); nullopt when not found.
std::optional<std::int64_t> stream_start_from_log(const std::string& agent_log_path);

// The wall-clock time of the first line of a keyfleet log containing any of `needles` (any
// line when empty); nullopt when none does.
std::optional<std::int64_t> log_time_of(const std::string& log_path,
                                        const std::vector<std::string>& needles);

// Counts the agent's "not sent now" warnings (writes refused by a full capped writer).
std::uint64_t count_refused_writes(const std::string& agent_log_path);

}  // namespace keyfleet::mission
