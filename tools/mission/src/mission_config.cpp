#include "keyfleet/mission/mission_config.hpp"

#include <filesystem>

#include "keyfleet/agent/agent_config_yaml.hpp"
#include "keyfleet/station/station_config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, MissionConfig& c) {
  v.field("name", c.name, file_name_check(64));
  v.field("drones", c.drones, between(1, 64));
  v.field("robot_id_prefix", c.robot_id_prefix);
  v.field("run_root", c.run_root);
  v.field("domain_id", c.domain_id, between(0, 232));
  v.field("agent_timeout_s", c.agent_timeout_s, positive());
  v.field("station_drain_timeout_s", c.station_drain_timeout_s, positive());
  v.field("scenario", c.scenario);
  v.field("scenario_dir", c.scenario_dir);
  v.field("security", c.security);
  v.field("scenario_drones", c.scenario_drones, between(0, 64));
  v.section("agent", c.agent);
  v.section("station", c.station);
}

template void visit(ConfigReader&, MissionConfig&);
template void visit(ConfigWriter&, MissionConfig&);

void validate(const MissionConfig& c, const std::string& origin) {
  validate(c.agent, origin + " (agent)");
  if (!is_valid_robot_id(c.robot_id_prefix + std::to_string(c.drones - 1)))
    throw ConfigError(origin + ": robot_id_prefix: '" + c.robot_id_prefix +
                      "' does not make valid robot ids ([A-Za-z0-9_-]{1,32})");
}

MissionConfig parse_mission_config(const std::string& text, const std::string& origin) {
  return parse_config<MissionConfig>(text, origin);
}

MissionConfig load_mission_config(const std::string& path) {
  MissionConfig config = parse_mission_config(read_config_file(path), path);
  resolve_relative_to(path, config.scenario);
  resolve_relative_to(path, config.scenario_dir);
  if (!config.scenario.empty() && !std::filesystem::is_regular_file(config.scenario))
    throw ConfigError(path + ": scenario: '" + config.scenario + "' does not exist");
  if (!config.scenario_dir.empty() && !std::filesystem::is_directory(config.scenario_dir))
    throw ConfigError(path + ": scenario_dir: '" + config.scenario_dir + "' is not a folder");
  return config;
}

std::string to_yaml(const MissionConfig& config) { return emit_config(config); }

}  // namespace keyfleet
