// `keyfleet experiment bandwidth CONFIG`: missions of several fleet sizes over emulated links.
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/mission/bandwidth_experiment.hpp"
#include "keyfleet/mission/experiment_config.hpp"

namespace keyfleet::commands {
namespace {

struct BandwidthOptions {
  std::string config;
  std::string run_root;
  std::vector<int> drones;
  std::vector<std::string> links;
};

void run_bandwidth(const BandwidthOptions& o) {
  BandwidthExperimentConfig config = load_bandwidth_experiment_config(o.config);
  if (!o.run_root.empty()) config.run_root = o.run_root;
  if (!o.drones.empty()) config.drones = o.drones;
  if (!o.links.empty()) config.links = o.links;
  Logger logger = make_logger("experiment", "info");
  ShutdownSignal shutdown;
  mission::MissionBinaries binaries{mission::find_sibling_executable("robot_agent"),
                                    mission::find_sibling_executable("ground_station")};
  mission::BandwidthExperiment experiment(config, binaries, logger, std::cout);
  const auto result = experiment.run(shutdown.stop);

  std::cout << "\n" << mission::experiment_table(result);
  for (const auto& skipped : result.skipped) std::cout << skipped << "\n";
  std::cout << "\nexperiment folder: " << result.dir
            << "\n  results.json, results.csv  per mission and robot"
            << "\n  report.md, *.png           the report with its plots"
            << "\n  missions/<mission>-*/      each mission's run folder\n";
  if (!result.report_written) std::cerr << "report not written: " << result.report_error << "\n";
  bool ok = !result.interrupted && result.report_written;
  for (const auto& m : result.missions)
    if (!m.ok) {
      ok = false;
      std::cerr << "mission " << m.name << " FAILED:\n";
      for (const auto& failure : m.failures) std::cerr << "  - " << failure << "\n";
    }
  if (result.interrupted) std::cerr << "experiment interrupted: partial results written\n";
  if (!ok) throw CLI::RuntimeError(1);
}

}  // namespace

void add_experiment_commands(CLI::App& app) {
  auto* experiment = app.add_subcommand("experiment", "measured experiments on this machine");
  experiment->require_subcommand(1);
  auto options = std::make_shared<BandwidthOptions>();
  auto* bandwidth = experiment->add_subcommand(
      "bandwidth", "missions of N drones x emulated links (DDS cap; netns + tc when root)");
  bandwidth
      ->add_option("config", options->config, "experiment YAML (configs/experiment_bandwidth.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  bandwidth->add_option("--run-root", options->run_root, "override where the folder is created");
  bandwidth->add_option("--drones", options->drones, "override the fleet sizes, e.g. --drones 2 4")
      ->check(CLI::Range(1, 64));
  bandwidth->add_option("--links", options->links, "override the link kinds: flow_control netns");
  bandwidth->callback([options] { run_reporting([&] { run_bandwidth(*options); }); });
}

}  // namespace keyfleet::commands
