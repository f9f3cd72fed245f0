#pragma once
#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <string>

// Each group of `keyfleet` subcommands lives in its own file and adds itself here.
namespace keyfleet::commands {

// Runs a subcommand's callback, reporting an error once; main's own handler only wraps the
// subcommands it dispatches itself.
template <typename F>
void run_reporting(F&& f) {
  try {
    f();
  } catch (const CLI::Error&) {
    throw;  // an exit code chosen by the command
  } catch (const std::exception& e) {
    std::cerr << "keyfleet: error: " << e.what() << "\n";
    throw CLI::RuntimeError(1);
  }
}

void add_station_commands(CLI::App& app);
void add_vocabulary_commands(CLI::App& app);
void add_experiment_commands(CLI::App& app);
void add_eval_commands(CLI::App& app);
void add_places_commands(CLI::App& app);
void add_ocr_commands(CLI::App& app);
void add_segmenter_commands(CLI::App& app);
void add_security_commands(CLI::App& app);
void add_bench_commands(CLI::App& app);
void add_config_commands(CLI::App& app);
// `selection triggers`, under the `selection` subcommand.
void add_trigger_commands(CLI::App& selection);

// Scores what a run's station read against the scenario it replayed (`keyfleet ocr score`, and
// the end of `keyfleet mission`): prints it and writes station/text_score.txt. Never throws: a
// run that cannot be scored says why.
void print_run_text_score(const std::string& run_dir, const std::string& scenario_dir);
}  // namespace keyfleet::commands
