#pragma once
// `keyfleet experiment bandwidth`: missions of several fleet sizes over several emulated
// links, each measured per robot from the station's database, written as results.json,
// results.csv and (through tools/report/bandwidth_report.py) report.md with plots.
#include <optional>
#include <ostream>
#include <set>
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

// A mission that replayed a generated street, judged against the street's ground truth from the
// station's database: the sign words it read (eval::score_run_text) and its place matches
// between robots (eval::score_run_places).
struct MissionAnalysis {
  std::size_t keyframes = 0;           // stored keyframes of the scenario's drones
  std::size_t analysed = 0;            // of those, analysed by the station before it stopped
  std::size_t visible_words = 0;       // distinct sign words fully visible in a stored keyframe
  std::size_t words_read = 0;          // of those, read where they were visible
  std::size_t words_read_in_time = 0;  // ... in keyframes stored within words_in_time_s
  bool in_time_known = true;       // false: a robot's stream start was not in its log (no latency)
  std::size_t words_reported = 0;  // every word the station stored
  std::size_t junk = 0;            // of those, no word of the street
  std::size_t place_matches = 0;   // stored matches between two robots' keyframes
  std::size_t place_matches_right = 0;  // of those, within 5 m on the street
  std::vector<std::string> read_words;  // distinct, sorted
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
  std::optional<MissionAnalysis> analysis;  // when the missions replayed a generated scenario
  std::string analysis_error;               // why there is none although a scenario was replayed
};

struct ExperimentResult {
  std::string dir;
  std::string scenario_dir;  // the replayed scenario; empty for a generated, folder or video source
  double flight_s = 0;       // each drone's flight (frames / fps); 0 when the source does not say
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

  void prepare_scenario(const std::string& dir);
  // in_time_known: every robot's stream start was found (the in-time words are measurable).
  void add_analysis(ExperimentMission& out,
                    const std::set<std::pair<std::string, std::int64_t>>& in_time,
                    bool in_time_known) const;

  BandwidthExperimentConfig config_;
  MissionBinaries binaries_;
  Logger logger_;
  std::ostream& progress_;
  std::string scenario_dir_;  // the replayed scenario, when mission.scenario* is set
  std::vector<std::string> scenario_drones_;  // its robot ids, in order
  double scenario_flight_s_ = 0;              // its drones' flight (frames / fps)
};

// Raises the agents' drain_timeout_s (and the mission's agent timeout) to what the flight offers
// (config.offered_bytes_per_s) beyond what the profile's link carries meanwhile, plus
// config.drain_margin_s, so that a slow or lossy link is not cut short by a fixed timeout.
// `flight_s`: the flight's length; 0 = from the agents' source (max_frames / fps).
void size_drain(MissionConfig& mission, const LinkProfileConfig& profile,
                const BandwidthExperimentConfig& config, double flight_s = 0);

// results.json / results.csv of an experiment (also read by the plotting script).
void write_experiment_json(const ExperimentResult& result, const BandwidthExperimentConfig& config,
                           const std::string& path);
void write_experiment_csv(const ExperimentResult& result, const std::string& path);
// The per-mission summary table printed at the end (with analysis_table's below it).
std::string experiment_table(const ExperimentResult& result);
// Missions that replayed a scenario: keyframes analysed, sign words read (and as a share of what
// the same flight read over an unlimited link), junk, place matches between robots (right ones)
// and the payload per drone per second of flight. Empty when no mission has an analysis.
std::string analysis_table(const ExperimentResult& result);

// tools/report/bandwidth_report.py, beside the binaries (share/keyfleet/report) or in the
// source tree; empty when neither exists.
std::string find_report_script();

}  // namespace keyfleet::mission
