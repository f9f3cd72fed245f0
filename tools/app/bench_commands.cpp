// `keyfleet bench fleet`: N agents plus the station, at real time and as fast as possible.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

#include "commands.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/mission/fleet_bench.hpp"
#include "keyfleet/mission/mission_config.hpp"

namespace keyfleet::commands {
namespace {

struct FleetOptions {
  mission::FleetBenchOptions bench;
  std::string trigger;
  std::string mode = "realtime";
};

int run_fleet(FleetOptions& o) {
  if (!o.trigger.empty()) {
    o.bench.trigger = trigger_kind(o.trigger);
    if (!o.bench.trigger)
      throw StartupError("--trigger: '" + o.trigger + "' is not one of " + trigger_kind_choices());
  }
  o.bench.realtime = o.mode != "fast";
  o.bench.fast = o.mode != "realtime";
  Logger logger = make_logger("bench", "warn");
  ShutdownSignal shutdown;
  mission::MissionBinaries binaries{mission::find_sibling_executable("robot_agent"),
                                    mission::find_sibling_executable("ground_station")};
  const auto runs = mission::run_fleet_bench(o.bench, binaries, logger, std::cout, shutdown.stop);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const std::string table = mission::format_fleet_table(runs, cores);
  std::printf("\n%s", table.c_str());
  // The figures depend on the CPU class: say which, and which kernels the agents' model ran.
  std::printf("%s\n",
              mission::fleet_cpu_lines(load_mission_config(o.bench.mission_config)).c_str());
  for (const auto& r : runs)
    for (const auto& f : r.failures) std::fprintf(stderr, "N=%d: %s\n", r.drones, f.c_str());
  return shutdown.stop.requested() ? 1 : 0;
}

}  // namespace

void add_bench_commands(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "benchmarks that run the real processes");
  bench->require_subcommand(1);
  auto o = std::make_shared<FleetOptions>();
  auto* fleet = bench->add_subcommand(
      "fleet", "N agents + the station on a generated scenario: real-time factor, CPU per stage");
  fleet->add_option("mission", o->bench.mission_config, "mission YAML (configs/demo_mission.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  fleet->add_option("--drones", o->bench.drones, "fleet sizes to run (default 1 2 4 6)")
      ->check(CLI::Range(1, 64));
  fleet->add_option("--frames", o->bench.frames, "frames per drone of the generated scenario");
  fleet
      ->add_option("--scenario-dir", o->bench.scenario_dir,
                   "a scenario generated before, with enough drones")
      ->check(CLI::ExistingDirectory);
  fleet->add_option("--trigger", o->trigger, "V-SLAM trigger (" + trigger_kind_choices() + ")");
  fleet->add_option("--mode", o->mode, "realtime, fast (as fast as possible) or both")
      ->check(CLI::IsMember({"realtime", "fast", "both"}));
  fleet->add_option("--out", o->bench.out, "where the runs go (default runs/)");
  fleet
      ->add_option("--realtime-threshold", o->bench.realtime_threshold,
                   "real time when every agent's flight / stream time reaches this")
      ->check(CLI::Range(0.1, 1.0));
  fleet->callback([o] {
    int code = 0;
    run_reporting([&] { code = run_fleet(*o); });
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace keyfleet::commands
