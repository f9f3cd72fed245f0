// The YAML descriptions of the settings both sides read (config.hpp): the DDS settings and the
// station's limits, instantiated for the three visitors (shared_config_yaml.hpp).
#include "keyfleet/common/shared_config_yaml.hpp"

#include <regex>

namespace keyfleet {

template <>
struct EnumNames<DdsSettings::Transport> {
  static constexpr std::pair<DdsSettings::Transport, const char*> kAll[] = {
      {DdsSettings::Transport::kLocalhost, "localhost"},
      {DdsSettings::Transport::kNetwork, "network"}};
};

template <class V>
void visit(V& v, DdsSecurity& c) {
  v.field("enabled", c.enabled);
  v.field("directory", c.directory);
}

template <class V>
void visit(V& v, DdsLinkProfile& c) {
  v.field("rate_kbit_s", c.rate_kbit_s, between(0.0, 10000000.0));
  v.field("mtu_bytes", c.mtu_bytes, between(576, 65535));
  v.field("pacing", c.pacing, between(0.1, 1.0));
  v.field("announcement_period_s", c.announcement_period_s, positive());
  v.field("lease_duration_s", c.lease_duration_s, positive());
  v.field("rejoin_after_s", c.rejoin_after_s, between(0.0, 86400.0));
}

template <class V>
void visit(V& v, DdsSettings& c) {
  v.field("domain_id", c.domain_id, between(0, 232));
  v.field("partition", c.partition,
          Check<std::string>(
              [](const std::string& s) {
                return s.empty() ? std::string("must not be empty") : std::string();
              },
              "not empty"));
  v.field("transport", c.transport);
  v.field("initial_peers", c.initial_peers);
  v.field("shared_memory", c.shared_memory);
  v.field("lease_duration_s", c.lease_duration_s, positive());
  v.field("announcement_period_s", c.announcement_period_s, positive());
  v.field("keyframe_history_depth", c.keyframe_history_depth, between(1, 1000));
  v.field("heartbeat_period_s", c.heartbeat_period_s, positive());
  v.field("max_bytes_per_s", c.max_bytes_per_s, between<std::uint64_t>(0, 100000000000ULL));
  v.section("link", c.link);
  v.section("security", c.security);
}

template <class V>
void visit(V& v, StationLimits& c) {
  using L = StationLimits;
  v.field("max_image_bytes", c.max_image_bytes, between<std::uint64_t>(1, L::kCapImageBytes));
  v.field("max_width", c.max_width, between<std::uint32_t>(1, L::kCapSide));
  v.field("max_height", c.max_height, between<std::uint32_t>(1, L::kCapSide));
  v.field("max_pixels", c.max_pixels, between<std::uint64_t>(1, L::kCapPixels));
  v.field("max_scans", c.max_scans, between(1, L::kCapScans));
  v.field("max_pixels_per_byte", c.max_pixels_per_byte, between(1.0, L::kCapPixelsPerByte));
  v.field("max_text_regions", c.max_text_regions, between(0, 100000));
  v.field("allowed_robots", c.allowed_robots);
  v.field("max_robots", c.max_robots, between(1, L::kCapRobots));
}

template void visit(ConfigReader&, DdsSettings&);
template void visit(ConfigWriter&, DdsSettings&);
template void visit(ConfigReference&, DdsSettings&);
template void visit(ConfigReader&, StationLimits&);
template void visit(ConfigWriter&, StationLimits&);
template void visit(ConfigReference&, StationLimits&);

void validate(const DdsSettings& dds, const std::string& origin) {
  if (dds.security.enabled && dds.security.directory.empty())
    throw ConfigError(origin + ": dds.security.directory: required when dds.security.enabled");
}

bool is_valid_robot_id(const std::string& robot_id) {
  static const std::regex pattern("[A-Za-z0-9_-]{1,32}");
  return std::regex_match(robot_id, pattern);
}

}  // namespace keyfleet
