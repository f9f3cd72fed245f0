#include "keyfleet/mission/experiment_config.hpp"

#include <filesystem>

#include "keyfleet/common/config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, LinkProfileConfig& c) {
  v.field("name", c.name, file_name_check(32));
  v.field("rate_kbit_s", c.rate_kbit_s, between(0.0, 1e7));
  v.field("delay_ms", c.delay_ms, between(0.0, 10000.0));
  v.field("loss_percent", c.loss_percent, between(0.0, 100.0));
}

template <class V>
void visit(V& v, BandwidthExperimentConfig& c) {
  v.field("name", c.name, file_name_check(64));  // part of the experiment folder's name
  v.field("run_root", c.run_root);
  v.field("drones", c.drones, Check<std::vector<int>>([](const std::vector<int>& counts) {
            for (int n : counts)
              if (n < 1 || n > 64) return std::string("every count must be between 1 and 64");
            return counts.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("profiles", c.profiles);
  v.field("links", c.links, Check<std::vector<std::string>>([](const std::vector<std::string>& l) {
            for (const auto& kind : l)
              if (kind != "flow_control" && kind != "netns")
                return std::string("each must be flow_control or netns");
            return l.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("netns_dds_cap_fraction", c.netns_dds_cap_fraction, between(0.0, 1.0));
  v.field("dds_link", c.dds_link);
  v.field("security", c.security,
          Check<std::vector<std::string>>([](const std::vector<std::string>& modes) {
            for (const auto& m : modes)
              if (m != "on" && m != "off") return std::string("each must be on or off");
            return std::string();
          }));
  v.field("link_adaptation", c.link_adaptation,
          Check<std::vector<std::string>>([](const std::vector<std::string>& modes) {
            for (const auto& m : modes)
              if (m != "on" && m != "off") return std::string("each must be on or off");
            return std::string();
          }));
  v.field("offered_bytes_per_s", c.offered_bytes_per_s, between(0.0, 1e9));
  v.field("drain_margin_s", c.drain_margin_s, between(0.0, 3600.0));
  v.field("idle_window_s", c.idle_window_s, between(0.0, 600.0));
  v.field("capture", c.capture);
  v.field("bin_s", c.bin_s, between(0.01, 60.0));
  v.field("words_in_time_s", c.words_in_time_s, between(0.0, 3600.0));
  v.field("python", c.python);
  v.section("mission", c.mission);
}

void validate(const BandwidthExperimentConfig& c, const std::string& origin) {
  validate(c.mission, origin + " (mission)");
  if (c.profiles.empty()) throw ConfigError(origin + ": profiles: must not be empty");
}

BandwidthExperimentConfig parse_bandwidth_experiment_config(const std::string& text,
                                                            const std::string& origin) {
  return parse_config<BandwidthExperimentConfig>(text, origin);
}

BandwidthExperimentConfig load_bandwidth_experiment_config(const std::string& path) {
  BandwidthExperimentConfig config =
      parse_bandwidth_experiment_config(read_config_file(path), path);
  // A replayed scenario is relative to the experiment file, as in a mission file.
  resolve_relative_to(path, config.mission.scenario);
  resolve_relative_to(path, config.mission.scenario_dir);
  if (!config.mission.scenario.empty() &&
      !std::filesystem::is_regular_file(config.mission.scenario))
    throw ConfigError(path + ": mission.scenario: '" + config.mission.scenario +
                      "' does not exist");
  if (!config.mission.scenario_dir.empty() &&
      !std::filesystem::is_directory(config.mission.scenario_dir))
    throw ConfigError(path + ": mission.scenario_dir: '" + config.mission.scenario_dir +
                      "' is not a folder");
  return config;
}

std::string to_yaml(const BandwidthExperimentConfig& config) { return emit_config(config); }

}  // namespace keyfleet
