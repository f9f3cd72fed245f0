// The YAML descriptions of the station's settings (station_config.hpp): one per struct, used by
// the reader, the writer and the reference; the cross-field checks and the loaders.
#include "keyfleet/station/station_config_yaml.hpp"

#include <regex>

#include "keyfleet/common/shared_config_yaml.hpp"
#include "keyfleet/station/places/place_recognition_config_yaml.hpp"
#include "keyfleet/station/text/text_reading_config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, AnalysisConfig& c) {
  v.field("workers", c.workers, between(1, 64));
  v.field("queue_capacity", c.queue_capacity, between(1, 100000));
  v.field("drain_timeout_s", c.drain_timeout_s, between(0.0, 3600.0));
  v.field("max_attempts", c.max_attempts, between(1, 1000));
  v.section("text", c.text);
  v.section("places", c.places);
}

template <class V>
void visit(V& v, DashboardConfig& c) {
  v.field("enabled", c.enabled);
  v.field("address", c.address);
  v.field("port", c.port, between(0, 65535));
  v.field("token", c.token);
  v.field("update_period_s", c.update_period_s, between(0.05, 60.0));
  v.field("thumbnails_per_robot", c.thumbnails_per_robot, between(1, 1000));
  v.field("threads", c.threads, between(1, 64));
  v.field("max_connections", c.max_connections, between(4, 4096));
  v.field("max_connections_per_client", c.max_connections_per_client, between(1, 4096));
  v.field("max_event_streams", c.max_event_streams, between(0, 1024));
  v.field("request_timeout_s", c.request_timeout_s, between(0.1, 300.0));
}

template <class V>
void visit(V& v, StationConfig& c) {
  v.section("dds", c.dds);
  v.section("limits", c.limits);
  v.section("analysis", c.analysis);
  v.section("dashboard", c.dashboard);
  v.field("database", c.database);
  v.field("mission_log", c.mission_log);
  v.field("report_period_s", c.report_period_s, positive());
  v.field("report_reserve_bytes", c.report_reserve_bytes, between<std::uint64_t>(0, 1ULL << 30));
  v.field("log_level", c.log_level, one_of(kLogLevels));
}

template void visit(ConfigReader&, StationConfig&);
template void visit(ConfigWriter&, StationConfig&);
template void visit(ConfigReference&, StationConfig&);

void validate(const StationConfig& c, const std::string& origin) {
  validate(c.dds, origin);
  for (const std::string& id : c.limits.allowed_robots)
    if (!is_valid_robot_id(id))
      throw ConfigError(origin + ": limits.allowed_robots: '" + id +
                        "' is not a robot id ([A-Za-z0-9_-]{1,32})");
  if (c.limits.allowed_robots.size() > static_cast<std::size_t>(c.limits.max_robots))
    throw ConfigError(
        origin + ": limits.allowed_robots: " + std::to_string(c.limits.allowed_robots.size()) +
        " robots, more than limits.max_robots (" + std::to_string(c.limits.max_robots) + ")");
  const DashboardConfig& d = c.dashboard;
  if (!d.token.empty() && d.token.size() < DashboardConfig::kMinTokenLength)
    throw ConfigError(origin + ": dashboard.token: " + std::to_string(d.token.size()) +
                      " characters, fewer than " +
                      std::to_string(DashboardConfig::kMinTokenLength) +
                      ": leave it out off loopback and the station generates a strong one");
  if (d.max_connections_per_client > d.max_connections || d.max_event_streams >= d.max_connections)
    throw ConfigError(origin + ": dashboard: max_connections_per_client (" +
                      std::to_string(d.max_connections_per_client) + ") and max_event_streams (" +
                      std::to_string(d.max_event_streams) +
                      ") must leave room within max_connections (" +
                      std::to_string(d.max_connections) + ")");
}

bool is_loopback_address(const std::string& address) {
  static const std::regex ipv4_loopback("127\\.[0-9]{1,3}\\.[0-9]{1,3}\\.[0-9]{1,3}");
  return address == "localhost" || address == "::1" || std::regex_match(address, ipv4_loopback);
}

StationConfig parse_station_config(const std::string& text, const std::string& origin) {
  return parse_config<StationConfig>(text, origin);
}
StationConfig load_station_config(const std::string& path) {
  StationConfig config = parse_station_config(read_config_file(path), path);
  resolve_relative_to(path, config.dds.security.directory);
  return config;
}
std::string to_yaml(const StationConfig& config) { return emit_config(config); }

}  // namespace keyfleet
