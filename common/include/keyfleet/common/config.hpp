#pragma once
// Every user-facing setting, as plain structs with their defaults and units.
// The YAML mapping of all of them lives in one place: config_yaml.cpp.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet {

// How a process joins the DDS network (see DESIGN.md §3 for why these defaults).
struct DdsSettings {
  enum class Transport {
    kLocalhost,  // SHM + UDPv4 on 127.0.0.1 only, no multicast: one-machine missions and tests
    kNetwork,    // Fast DDS's built-in transports on all interfaces, plus initial_peers
  };
  int domain_id = 0;                   // 0..232; overridden by --domain / KEYFLEET_DOMAIN
  std::string partition = "keyfleet";  // overridden by --partition / KEYFLEET_PARTITION
  Transport transport = Transport::kLocalhost;
  std::vector<std::string> initial_peers;  // kNetwork: IPv4 addresses of other hosts
  double lease_duration_s = 4.0;           // a silent peer is dropped after this long
  double announcement_period_s = 1.0;      // participant announcements
  int keyframe_history_depth = 5;          // KEEP_LAST depth of the keyframe writer
  double heartbeat_period_s = 0.1;         // reliable writer heartbeat
};

struct SourceConfig {
  enum class Kind { kGenerated, kImageFolder, kVideoFile };
  Kind kind = Kind::kGenerated;
  std::string path;              // image folder or video file (kImageFolder, kVideoFile)
  double fps = 30.0;             // frame rate of the stream (also the timestamps' rate)
  bool realtime = true;          // pace frames at fps; false = as fast as possible
  std::uint64_t max_frames = 0;  // stop after this many frames; 0 = whole source
                                 // (kGenerated: 0 = fly until stopped)
  int width = 640;               // kGenerated: frame size in pixels
  int height = 480;
  std::uint64_t seed = 1;  // kGenerated: scene and flight seed
};

struct SelectorConfig {
  enum class Strategy { kStride };
  Strategy strategy = Strategy::kStride;
  int stride = 15;  // kStride: one keyframe every `stride` frames
};

struct CodecConfig {
  int jpeg_quality = 85;  // 1..100
};

struct LedgerConfig {
  // Encode one frame in N as JPEG to estimate what streaming every frame would cost
  // (1 = measure every frame; the report labels extrapolated figures as estimated).
  int baseline_sample_every = 10;
};

// Keyframes stay in the agent's on-disk outbox until the station acknowledges that
// they are stored; unacknowledged ones are sent again. The bounds decide when the agent
// gives up on the oldest (each drop is logged and counted in AgentStats).
struct OutboxConfig {
  std::string path = "outbox.sqlite";  // relative to the run directory
  std::uint64_t max_pending = 1000;    // unacknowledged keyframes kept at most
  double max_age_s = 3600.0;           // oldest unacknowledged keyframe kept at most this long (s)
  double resend_after_s = 2.0;         // resend when unacknowledged this long (s)
  int resend_batch = 20;               // at most this many retransmissions per resend pass
};

struct AgentConfig {
  std::string robot_id = "drone_0";  // [A-Za-z0-9_-]{1,32}
  SourceConfig source;
  SelectorConfig selector;
  CodecConfig codec;
  LedgerConfig ledger;
  OutboxConfig outbox;
  DdsSettings dds;
  double stats_period_s = 1.0;       // AgentStats publication period
  double wait_for_station_s = 10.0;  // at start, wait this long for a station before streaming
  double drain_timeout_s = 60.0;     // at the end, wait this long for every acknowledgement
  std::string log_level = "info";    // trace, debug, info, warn, error
};

struct StationLimits {
  std::uint64_t max_image_bytes = 8ULL << 20;  // larger samples are rejected
  std::uint32_t max_width = 8192;              // claimed or decoded dimensions above these
  std::uint32_t max_height = 8192;             //   are rejected before decoding
};

struct StationConfig {
  DdsSettings dds;
  StationLimits limits;
  std::string database = "station.sqlite";  // relative to the run directory
  std::string mission_log = "mission_log.pb";
  double report_period_s = 5.0;  // live bandwidth line in the log
  std::string log_level = "info";
};

struct MissionConfig {
  std::string name = "mission";
  int drones = 3;
  std::string robot_id_prefix = "drone_";  // drone i is <prefix><i>
  std::string run_root = "runs";           // each run gets <run_root>/<name>-<timestamp>/
  std::optional<int> domain_id;            // default: derived from the process id
  double agent_timeout_s = 900.0;          // an agent still running after this fails the mission
  double station_drain_timeout_s = 60.0;   // after SIGTERM, the station must exit within this
  AgentConfig agent;                       // template for every drone; seed += drone index
  StationConfig station;
};

// Loaders throw ConfigError naming the file, the key and what is allowed.
AgentConfig load_agent_config(const std::string& path);
StationConfig load_station_config(const std::string& path);
MissionConfig load_mission_config(const std::string& path);

std::string to_yaml(const AgentConfig& config);
std::string to_yaml(const StationConfig& config);
std::string to_yaml(const MissionConfig& config);

// Parses YAML text (for tests and generated configs); `origin` names it in errors.
AgentConfig parse_agent_config(const std::string& text, const std::string& origin);
StationConfig parse_station_config(const std::string& text, const std::string& origin);
MissionConfig parse_mission_config(const std::string& text, const std::string& origin);

bool is_valid_robot_id(const std::string& robot_id);

}  // namespace keyfleet
