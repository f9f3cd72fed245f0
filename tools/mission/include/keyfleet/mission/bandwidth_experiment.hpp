#pragma once
// `keyfleet experiment bandwidth`: missions of several fleet sizes over several emulated
// links, each measured per robot from the station's database, written as results.json,
// results.csv and (through tools/report/bandwidth_report.py) report.md with plots.
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/mission/bandwidth_metrics.hpp"
#include "keyfleet/mission/experiment_config.hpp"
#include "keyfleet/mission/mission_runner.hpp"
#include "keyfleet/mission/rtps_accounting.hpp"

namespace keyfleet::mission {

struct RobotOutcome {
  RobotMetrics metrics;
  std::uint64_t frames_seen = 0;
  bool latency_measured = false;             // the stream start was found in the agent log
  std::vector<std::uint64_t> bytes_per_bin;  // from the mission's first receipt
  std::uint64_t pending = 0;                 // keyframes still in the outbox at the end (lost)
  // From the agent's start (its log's first line): its station matched (discovery and the
  // DDS-Security handshake), and its first keyframe stored at the station.
  std::optional<double> matched_s;
  std::optional<double> first_keyframe_s;
  // netns with capture: where the drone's bytes went, both directions.
  std::optional<WireAccount> wire_account;
  std::string capture_error;  // why there is no wire_account, when one was asked for
  // Stored payload over the time the keyframe writer was busy (data or repairs on the link),
  // as a fraction of the link's rate; 0 when not captured.
  double goodput_fraction = 0;
};

struct ExperimentMission {
  std::string name;
  std::string link;              // flow_control | netns
  bool security = true;          // DDS-Security on
  bool link_adaptation = false;  // the agents fit what they send to their link
  bool dds_link = false;         // DDS tuned for the link (dds.link from the profile)
  LinkProfileConfig profile;
  int drones = 0;
  std::uint64_t dds_cap_bytes_per_s = 0;  // per agent; 0 = none
  bool ok = false;
  double wall_s = 0;
  std::string run_dir;
  std::vector<std::string> failures;
  std::vector<std::string> notes;  // what the link applied and did not
  std::vector<RobotOutcome> robots;
};

struct ExperimentResult {
  std::string dir;
  std::vector<ExperimentMission> missions;
  std::vector<std::string> skipped;  // e.g. "netns: not running as root ..."
  bool interrupted = false;
  bool report_written = false;
  std::string report_error;
};

class BandwidthExperiment {
 public:
  BandwidthExperiment(BandwidthExperimentConfig config, MissionBinaries binaries, Logger logger,
                      std::ostream& progress);
  ExperimentResult run(const StopToken& stop);

 private:
  ExperimentMission run_mission(const std::string& dir, const std::string& link, bool security,
                                bool adaptation, int drones, const LinkProfileConfig& profile,
                                const StopToken& stop);

  BandwidthExperimentConfig config_;
  MissionBinaries binaries_;
  Logger logger_;
  std::ostream& progress_;
};

// Raises the agents' drain_timeout_s (and the mission's agent timeout) to what the flight offers
// (config.offered_bytes_per_s) beyond what the profile's link carries meanwhile, plus
// config.drain_margin_s, so that a slow or lossy link is not cut short by a fixed timeout.
void size_drain(MissionConfig& mission, const LinkProfileConfig& profile,
                const BandwidthExperimentConfig& config);

// results.json / results.csv of an experiment (also read by the plotting script).
void write_experiment_json(const ExperimentResult& result, const BandwidthExperimentConfig& config,
                           const std::string& path);
void write_experiment_csv(const ExperimentResult& result, const std::string& path);
// The per-mission summary table printed at the end.
std::string experiment_table(const ExperimentResult& result);

// tools/report/bandwidth_report.py, beside the binaries (share/keyfleet/report) or in the
// source tree; empty when neither exists.
std::string find_report_script();

}  // namespace keyfleet::mission
