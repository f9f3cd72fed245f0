#pragma once
// `keyfleet mission`: one station and N agents, loaded from YAML by mission_config.cpp.
#include <optional>
#include <string>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet {

struct MissionConfig {
  std::string name = "mission";
  int drones = 3;
  std::string robot_id_prefix = "drone_";  // drone i is <prefix><i>
  std::string run_root = "runs";           // each run gets <run_root>/<name>-<timestamp>/
  std::optional<int> domain_id;            // default: derived from the process id
  double agent_timeout_s = 900.0;          // an agent still running after this fails the mission
  double station_drain_timeout_s = 60.0;   // after SIGTERM, the station must exit within this
  // Replay a generated scenario: `scenario` names a scenario YAML (relative to the mission
  // file) generated into the run folder; `scenario_dir` names one generated before. Either
  // sets the drones (one agent per scenario drone, source kind scenario).
  std::string scenario;
  std::string scenario_dir;
  int scenario_drones = 0;  // fly only the scenario's first this many drones; 0 = all
  // DDS-Security for every participant: throwaway credentials (fleet_credentials.hpp) made into
  // <run folder>/security at start. false: plain DDS, anyone on the domain can read and write.
  bool security = true;
  AgentConfig agent;  // template for every drone; seed += drone index
  StationConfig station;
};

// Paths in a mission file are relative to the file. Throws ConfigError.
MissionConfig load_mission_config(const std::string& path);
MissionConfig parse_mission_config(const std::string& text, const std::string& origin);
std::string to_yaml(const MissionConfig& config);

template <class V>
void visit(V& v, MissionConfig& c);
void validate(const MissionConfig& config, const std::string& origin);

}  // namespace keyfleet
