// `keyfleet config reference`: every key of the agent's and the station's config files, with
// its type, default and allowed values, as Markdown (the generated part of
// docs/configuration.md; scripts/docs_config.sh puts it there).
#include <iostream>

#include "commands.hpp"
#include "keyfleet/mission/config_reference.hpp"

namespace keyfleet::commands {

void add_config_commands(CLI::App& app) {
  auto* config = app.add_subcommand("config", "the configuration files' keys");
  config->require_subcommand(1);
  auto* reference = config->add_subcommand(
      "reference", "print every key with its type, default and allowed values (Markdown)");
  reference->callback([] { run_reporting([] { std::cout << config_reference_markdown(); }); });
}

}  // namespace keyfleet::commands
