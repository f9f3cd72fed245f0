#pragma once
#include <ostream>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/shutdown_signal.hpp"

namespace keyfleet::mission {

struct MissionBinaries {
  std::string robot_agent;
  std::string ground_station;
};

struct MissionResult {
  bool ok = false;
  std::string run_dir;
  std::string report_table;           // the station's bandwidth report
  std::vector<std::string> failures;  // one line per failed process, saying why
};

// Runs one mission on this machine: a ground station and N agents as separate processes
// on a domain id and partition of their own, progress on `progress`, then drains and
// stops the station and collects its report.
class MissionRunner {
 public:
  MissionRunner(MissionConfig config, MissionBinaries binaries, Logger logger,
                std::ostream& progress);
  MissionResult run(const StopToken& stop);

 private:
  MissionConfig config_;
  MissionBinaries binaries_;
  Logger logger_;
  std::ostream& progress_;
};

// Finds a sibling executable of the running program (all keyfleet binaries install side
// by side), else on PATH. Throws StartupError naming what is missing.
std::string find_sibling_executable(const std::string& name);

}  // namespace keyfleet::mission
