// The YAML config loader on hostile text: the first byte picks the agent's, the station's or
// a mission's config, the rest is the file. A config is either refused with a ConfigError (any
// other exception is a finding) or accepted; an accepted one, written back as YAML, reads
// again to the same YAML.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "keyfleet/agent/agent_config_yaml.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/mission/mission_config.hpp"
#include "keyfleet/station/station_config_yaml.hpp"

namespace {

template <class Config>
void check(const std::string& text) {
  Config config;
  try {
    config = keyfleet::parse_config<Config>(text, "fuzz.yaml");
  } catch (const keyfleet::ConfigError&) {
    return;
  }
  const std::string written = keyfleet::emit_config(config);
  const Config again = keyfleet::parse_config<Config>(written, "fuzz.yaml (written back)");
  if (keyfleet::emit_config(again) != written) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 3) {
    case 0: check<keyfleet::AgentConfig>(text); break;
    case 1: check<keyfleet::StationConfig>(text); break;
    default: check<keyfleet::MissionConfig>(text); break;
  }
  return 0;
}
