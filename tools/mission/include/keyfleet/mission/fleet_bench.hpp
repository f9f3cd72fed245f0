#pragma once
// `keyfleet bench fleet`: how many agents (plus the station) keep real time on this machine.
// Each N runs as a real mission (separate processes, their own DDS domain and partition) on
// the first N drones of one generated scenario; the figures come from each agent's
// stream.json, the processes' CPU (wait4) and the station's database, and go to fleet.json in
// the bench's folder after every run.
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/common/types.hpp"
#include "keyfleet/mission/mission_runner.hpp"

namespace keyfleet::mission {

struct FleetBenchOptions {
  std::string mission_config;  // agent and station settings, and the scenario YAML
  std::string scenario_dir;    // a scenario generated before (enough drones), else generated
  std::vector<int> drones = {1, 2, 4, 6};
  std::uint64_t frames = 0;  // frames per drone when generating; 0 = the scenario's
  bool realtime = true;      // replay at the camera's rate
  bool fast = false;         // also as fast as possible
  std::optional<TriggerConfig::Kind> trigger;  // overrides the mission's
  std::string out = "runs";
  // Real time: every agent's flight time / stream time at least this (a 20 s flight replayed
  // within 0.4 s of its schedule at 0.98).
  double realtime_threshold = 0.98;
};

// What one agent's stream.json says.
struct AgentStreamFigures {
  std::string robot_id;
  std::uint64_t frames = 0;
  double fps = 0;
  double stream_s = 0;
  std::uint64_t late_frames = 0;
  double max_lag_ms = 0;
  double process_cpu_s = 0;
  double stream_cpu_s = 0;  // the process's CPU while streaming (0 in files from before it)
  std::map<std::string, StageTime> stages;
};
// Throws std::runtime_error naming the file when it is missing or malformed.
AgentStreamFigures read_stream_summary(const std::string& path, const std::string& robot_id);

// The station's analysis, summed over the keyframes it analysed (wall ms in its workers, and the
// reading's CPU ms on the worker's thread).
struct StationFigures {
  double cpu_s = 0;
  double start_cpu_s = 0;  // of cpu_s, to start (station/process.json; 0 when absent)
  std::uint64_t keyframes = 0;
  double text_ms = 0, places_ms = 0, text_cpu_ms = 0;
  // From a keyframe's arrival at the analysis queue to its result, seconds (process.json; a
  // negative p95 when absent): near one keyframe's analysis while the station keeps up. When
  // it reads behind, its bounded queue defers the oldest keyframes to after the flight: the lag
  // then stops at the queue's length, and `deferred` counts them.
  double read_lag_p95_s = -1, read_lag_max_s = -1;
  std::int64_t deferred = -1;  // -1: not written
};

struct FleetRunFigures {
  int drones = 0;
  bool realtime = true;
  double wall_s = 0;                 // the agents' replay, from starting them to the last one's end
  double rtf_min = 0, rtf_mean = 0;  // flight time / stream time over the agents
  std::uint64_t frames = 0, late_frames = 0;
  double max_lag_ms = 0;
  double agent_cpu_ms_per_frame = 0;                 // agents' processes, all threads
  double agent_stream_cpu_ms_per_frame = 0;          // the same from first frame to last
  std::map<std::string, double> stage_ms_per_frame;  // agents' stages, calling thread
  double station_cpu_ms_per_frame = 0;
  double station_work_cpu_ms_per_frame = 0;  // the same without its start
  std::uint64_t station_keyframes = 0;
  double station_text_ms_per_keyframe = 0, station_places_ms_per_keyframe = 0;
  double station_text_cpu_ms_per_keyframe = 0;
  double station_read_lag_p95_s = -1, station_read_lag_max_s = -1;  // StationFigures' read lag
  std::int64_t station_deferred = -1;
  double frames_per_s_per_core = 0;  // all agents' frames / wall time / cores
  bool keeps_realtime = false;
  std::vector<std::string> failures;
};

// The arithmetic of one run, from its parts (tested on hand-made timings).
FleetRunFigures fleet_figures(int drones, bool realtime,
                              const std::vector<AgentStreamFigures>& agents,
                              const StationFigures& station, double wall_s, unsigned cores,
                              double realtime_threshold);

// The largest N among the real-time runs whose every run up to it kept real time.
std::optional<int> largest_realtime(const std::vector<FleetRunFigures>& runs);

// The figures as a text table, then the per-stage CPU table.
std::string format_fleet_table(const std::vector<FleetRunFigures>& runs, unsigned cores);

// The CPU class the figures were taken on and the kernels the mission's agents and station run
// (vision/cpu_class.hpp): the lines the benchmark prints after its table.
std::string fleet_cpu_lines(const MissionConfig& mission);

// Every figure of the runs as JSON (fleet.json beside the runs): {"cores", "largest_realtime"
// (null where none), "cpu" (fleet_cpu_lines), "runs": [one object per run, the fields of
// FleetRunFigures by name; a figure the station did not write is null]}.
nlohmann::json fleet_json(const std::vector<FleetRunFigures>& runs, unsigned cores,
                          const std::string& cpu);

std::vector<FleetRunFigures> run_fleet_bench(const FleetBenchOptions& options,
                                             const MissionBinaries& binaries, Logger logger,
                                             std::ostream& progress, const StopToken& stop);

}  // namespace keyfleet::mission
