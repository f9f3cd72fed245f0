// keyfleet: the user's entry point. Subcommands: mission.
#include <CLI/CLI.hpp>

#include <iostream>

#include "keyfleet/common/config.hpp"
#include "keyfleet/mission/mission_runner.hpp"

namespace {

using namespace keyfleet;

int run_mission(const std::string& config_path, int drones, const std::string& run_root) {
  MissionConfig config = load_mission_config(config_path);
  if (drones > 0) config.drones = drones;
  if (!run_root.empty()) config.run_root = run_root;
  Logger logger = make_logger("mission", "info");
  ShutdownSignal shutdown;
  mission::MissionBinaries binaries{mission::find_sibling_executable("robot_agent"),
                                    mission::find_sibling_executable("ground_station")};
  mission::MissionRunner runner(config, binaries, logger, std::cout);
  const mission::MissionResult result = runner.run(shutdown.stop);
  std::cout << "\n" << result.report_table;
  std::cout << "\nrun folder: " << result.run_dir
            << "\n  station/station.sqlite  keyframes (SQLite)"
               "\n  station/mission_log.pb  mission log (protobuf, length-delimited)"
               "\n  station/report.{txt,json,csv}  bandwidth report"
               "\n  <robot>/agent.log, station/station.log  process logs\n";
  if (!result.ok) {
    std::cerr << "\nmission FAILED:\n";
    for (const auto& failure : result.failures) std::cerr << "  - " << failure << "\n";
    return 1;
  }
  std::cout << "mission OK\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  keyfleet::block_termination_signals();
  CLI::App app{"keyfleet: keyframe sharing for robot fleets over weak links"};
  app.require_subcommand(1);

  auto* mission =
      app.add_subcommand("mission", "run a simulated multi-drone mission on this machine");
  std::string config_path;
  int drones = 0;
  std::string run_root;
  mission->add_option("config", config_path, "mission YAML (see configs/demo_mission.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  mission->add_option("--drones", drones, "override the number of drones")
      ->check(CLI::Range(1, 64));
  mission->add_option("--run-root", run_root, "override where run folders are created");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*mission) return run_mission(config_path, drones, run_root);
  } catch (const std::exception& e) {
    std::cerr << "keyfleet: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
