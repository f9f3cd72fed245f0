#pragma once
#include <CLI/CLI.hpp>

// Each group of `keyfleet` subcommands lives in its own file and adds itself here.
namespace keyfleet::commands {
void add_vocabulary_commands(CLI::App& app);
void add_ocr_commands(CLI::App& app);
}  // namespace keyfleet::commands
