#include "keyfleet/mission/config_reference.hpp"

#include "keyfleet/agent/agent_config_yaml.hpp"
#include "keyfleet/station/station_config_yaml.hpp"

namespace keyfleet {

std::string config_reference_markdown() {
  return config_reference_table(
             "Agent",
             "`robot_agent --config FILE` (`configs/agent.yaml`), and `agent:` in a "
             "mission file: `AgentConfig`.",
             config_keys<AgentConfig>()) +
         "\n" +
         config_reference_table(
             "Station",
             "`ground_station --config FILE` (`configs/station.yaml`), and `station:` "
             "in a mission file: `StationConfig`.",
             config_keys<StationConfig>());
}

}  // namespace keyfleet
