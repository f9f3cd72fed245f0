#pragma once
// Command-line options shared by robot_agent and ground_station (header-only: CLI11 is
// needed by the executables only).
#include <CLI/CLI.hpp>

#include <iostream>
#include <optional>
#include <string>

#include "keyfleet/common/config.hpp"
#include "keyfleet/dds/dds_transport.hpp"

namespace keyfleet {

struct ProcessOptions {
  std::string config_path;
  std::string run_dir = ".";
  std::string log_file;
  std::optional<int> domain;
  std::string partition;
};

inline void add_process_options(CLI::App& app, ProcessOptions& o, const std::string& config_what) {
  app.add_option("-c,--config", o.config_path, config_what)->required()->check(CLI::ExistingFile);
  app.add_option("--run-dir", o.run_dir, "folder for this process's files");
  app.add_option("--log-file", o.log_file, "also log to this file");
  app.add_option("--domain", o.domain, "DDS domain id (overrides config and KEYFLEET_DOMAIN)")
      ->check(CLI::Range(0, 232));
  app.add_option("--partition", o.partition,
                 "DDS partition (overrides config and KEYFLEET_PARTITION)");
}

// Config, then the environment, then the command line.
inline void apply_dds_overrides(const ProcessOptions& o, DdsSettings& dds) {
  apply_dds_environment(dds);
  if (o.domain) dds.domain_id = *o.domain;
  if (!o.partition.empty()) dds.partition = o.partition;
}

// Runs `body`, reporting a start-up error once, with the program's name, as exit code 1.
template <class Body>
int run_reporting_errors(const char* program, Body&& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace keyfleet
