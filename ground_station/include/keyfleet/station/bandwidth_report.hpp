#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/common/robot_admission.hpp"
#include "keyfleet/station/keyframe_store.hpp"

namespace keyfleet::station {

// One line of the report: what the station received from a robot, against what the
// robot says streaming every frame or every V-SLAM keyframe would have cost.
struct BandwidthRow {
  std::string robot_id;  // "FLEET" for the sum
  std::uint64_t keyframes_stored = 0;
  std::uint64_t rejected = 0;
  std::uint64_t conflicts = 0;       // kept apart: their sequence number held another image
  std::uint64_t bytes_received = 0;  // serialized samples, first copies, measured at the station
  // The part of bytes_received from robots whose stats (and so baselines) are known:
  // savings compare like with like.
  std::uint64_t bytes_received_with_baseline = 0;
  std::uint64_t frames_seen = 0;
  std::uint64_t vslam_keyframes = 0;
  std::uint64_t keyframes_sent = 0;
  std::uint64_t keyframes_resent = 0;
  std::uint64_t keyframes_dropped = 0;
  std::uint64_t keyframes_pending = 0;
  std::uint64_t bytes_sent_total = 0;  // agent's own count, retransmissions included
  std::uint64_t stream_all_bytes = 0;
  bool stream_all_estimated = false;
  std::uint64_t vslam_keyframe_bytes = 0;
  bool vslam_keyframe_estimated = false;
  // The robot's link adaptation (its latest stats): keyframes sent reduced and held back, level
  // changes, the level now and its link as it estimates it.
  std::uint64_t keyframes_reduced = 0;
  std::uint64_t keyframes_thinned = 0;
  std::uint64_t level_changes = 0;
  std::uint32_t send_quality = 0;
  double send_scale = 1.0;
  std::uint32_t send_density = 1;
  double link_bytes_per_s = 0;
  double link_rtt_ms = 0;
  double backlog_s = 0;
  bool has_agent_stats = false;
  bool agent_finished = false;
  double keyframes_per_minute = 0;      // over the span the station received them
  double saving_vs_stream_all() const;  // stream_all_bytes / bytes_received_with_baseline
  double saving_vs_vslam() const;
};

struct BandwidthReport {
  std::vector<BandwidthRow> robots;
  BandwidthRow fleet;
  // Robots the station did not serve (limits.allowed_robots, max_robots): nothing of theirs is
  // stored, so this is known only to the running station, which sets it before writing.
  RobotRefusals refused;
  // Whether the station ran with DDS-Security (set by the running station): a report of a run
  // without it says so.
  bool dds_security = true;
};

BandwidthReport build_bandwidth_report(const std::vector<RobotTotals>& totals);

std::string format_table(const BandwidthReport& report);
std::string to_json(const BandwidthReport& report);
std::string to_csv(const BandwidthReport& report);

// Bytes over time for one robot: what the station received (cumulative, at its receive times)
// against the two baselines as the robot had counted them (at its stats reports).
struct BandwidthPoint {
  std::int64_t time_ns = 0;
  std::uint64_t bytes = 0;
};
struct BandwidthSeries {
  std::string robot_id;
  std::vector<BandwidthPoint> received, stream_all, vslam_keyframes;
};

// One series per robot that sent keyframes or stats, by robot id.
std::vector<BandwidthSeries> build_bandwidth_timeline(
    const std::vector<StoredKeyframeInfo>& keyframes, const std::vector<StatsSample>& stats);

// Writes report.json and report.csv into `run_dir`; returns the table text.
std::string write_bandwidth_report(const BandwidthReport& report, const std::string& run_dir);

}  // namespace keyfleet::station
