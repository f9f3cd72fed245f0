#pragma once
// The station's settings (ground_station --config, a mission's station:), as plain structs with
// their defaults and units; the text reader's, place recognition's and the dashboard's in their
// own headers. Their YAML descriptions: station_config_yaml.hpp (station_config_yaml.cpp).
#include <cstdint>
#include <string>

#include "keyfleet/common/config.hpp"
#include "keyfleet/station/dashboard_config.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"

namespace keyfleet {

// The station's heavier work, behind the DDS reader: a bounded queue and worker threads.
struct AnalysisConfig {
  int workers = 1;
  // Keyframes waiting for analysis; beyond it the oldest waiting one is deferred (its heavy
  // steps run later, when the queue is empty). A stored keyframe is never dropped.
  int queue_capacity = 32;
  // At shutdown the station finishes queued analysis for at most this long; what is left
  // stays unanalysed in the database and is analysed when the station next starts.
  double drain_timeout_s = 40.0;
  // A keyframe whose analysis was started this many times and never finished (the station
  // died in it each time, a crash in an engine) is marked failed and not analysed again.
  int max_attempts = 3;
  TextReadingConfig text;
  PlaceRecognitionConfig places;
};

struct StationConfig {
  DdsSettings dds;
  StationLimits limits;
  AnalysisConfig analysis;
  DashboardConfig dashboard;
  std::string database = "station.sqlite";  // relative to the run directory
  std::string mission_log = "mission_log.pb";
  double report_period_s = 5.0;  // live bandwidth line in the log
  // Disk space the station holds in <run>/report.reserve from its start and frees just before
  // writing its reports, so that they are written even after the disk filled up.
  std::uint64_t report_reserve_bytes = 4u << 20;
  std::string log_level = "info";
};

// Loaders throw ConfigError naming the file, the key and what is allowed.
StationConfig load_station_config(const std::string& path);
std::string to_yaml(const StationConfig& config);
// Parses YAML text (for tests and generated configs); `origin` names it in errors.
StationConfig parse_station_config(const std::string& text, const std::string& origin);

}  // namespace keyfleet
