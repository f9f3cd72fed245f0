#pragma once
#include <filesystem>
#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/mission/child_process.hpp"
#include "keyfleet/mission/mission_config.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet::mission {

struct MissionBinaries {
  std::string robot_agent;
  std::string ground_station;
};

// One process of a mission: where it wrote its files and the CPU it used (all its threads).
struct ProcessFigures {
  std::string name;
  std::string run_dir;
  double cpu_s = 0;
};

struct MissionResult {
  bool ok = false;
  std::string run_dir;
  std::string report_table;           // the station's bandwidth report
  std::string scenario_dir;           // the scenario replayed, when there was one
  std::string dashboard_url;          // the station's live dashboard, when it served one
  std::string report_html;            // <run_dir>/report.html, when written
  std::vector<std::string> failures;  // one line per failed process, saying why
  std::vector<ProcessFigures> agents;
  ProcessFigures station;
  double agents_wall_s = 0;  // from starting the agents to the last one's end
};

// Optional changes to how a mission's processes run (the bandwidth experiment's links).
struct MissionHooks {
  // Called for drone `index` once its config is made, before it is written.
  std::function<void(std::size_t index, AgentConfig&)> adjust_agent;
  // Words put before a process's command line ("ground_station" or a robot id), e.g.
  // `ip netns exec NS`.
  std::function<std::vector<std::string>(const std::string& process)> command_prefix;
};

// What a mission runs, decided before any process starts: its drones, its DDS domain and
// partition, and each process's config.
struct MissionPlan {
  std::filesystem::path run_dir;
  int domain_id = 0;
  std::string partition;
  std::string scenario_dir;  // the scenario replayed, or empty
  std::vector<std::string> robot_ids;
  StationConfig station;            // serves robot_ids only
  std::vector<AgentConfig> agents;  // one per robot id, in the same order
};

// The plan of a mission of `robot_ids` in `run_dir` (no file is written): the station serves
// those robots only; each agent replays its scenario drone (when `scenario_dir` is given) with
// its own seed; with `config.security` each process gets its host's bundle under
// run_dir/security/hosts (fleet_credentials.hpp), else security is off for all; `adjust_agent`
// (the hooks') last.
MissionPlan plan_mission(const MissionConfig& config, const std::filesystem::path& run_dir,
                         std::vector<std::string> robot_ids, const std::string& scenario_dir,
                         int domain_id, const std::string& partition,
                         const std::function<void(std::size_t, AgentConfig&)>& adjust_agent = {});

// Runs one mission on this machine: a ground station and N agents as separate processes
// on a domain id and partition of their own, progress on `progress`, then drains and
// stops the station and collects its report.
class MissionRunner {
 public:
  MissionRunner(MissionConfig config, MissionBinaries binaries, Logger logger,
                std::ostream& progress);
  MissionResult run(const StopToken& stop);
  void set_hooks(MissionHooks hooks) { hooks_ = std::move(hooks); }

 private:
  struct Processes {
    std::unique_ptr<ChildProcess> station;
    std::vector<std::unique_ptr<ChildProcess>> agents;
  };
  std::filesystem::path make_run_folder() const;
  std::vector<std::string> choose_drones(const std::filesystem::path& run_dir,
                                         std::string& scenario_dir);
  void write_plan(const MissionPlan& plan);
  Processes start(const MissionPlan& plan);
  bool watch(Processes& processes, const MissionPlan& plan, const StopToken& stop,
             MissionResult& result);
  void note_dashboard(const std::filesystem::path& station_dir, MissionResult& result);
  void stop_processes(Processes& processes, bool station_died, MissionResult& result);
  void collect(const MissionPlan& plan, Processes& processes, MissionResult& result);
  std::vector<std::string> command(const std::string& process, std::vector<std::string> argv) const;
  // report.html from the station's database (and the scenario's ground truth).
  void write_report_html(const std::filesystem::path& run_dir, MissionResult& result) const;

  MissionHooks hooks_;
  MissionConfig config_;
  MissionBinaries binaries_;
  Logger logger_;
  std::ostream& progress_;
};

// Finds a sibling executable of the running program (all keyfleet binaries install side
// by side), else on PATH. Throws StartupError naming what is missing.
std::string find_sibling_executable(const std::string& name);

}  // namespace keyfleet::mission
