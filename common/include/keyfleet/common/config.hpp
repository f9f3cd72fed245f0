#pragma once
// The settings both sides of the link read, as plain structs with their defaults and units: how
// a process joins the DDS network, and what the station accepts from a robot (checked by
// common's robot admission and JPEG header reader and by the DDS adapter). Each library's own
// settings live with it: the agent's in agent/agent_config.hpp, the station's in
// station/station_config.hpp, the text reader's, place recognition's and the segmenter's in their
// libraries. Their YAML descriptions: shared_config_yaml.hpp (these), and each library's
// *_config_yaml.hpp.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet {

// How a process joins the DDS network. Fast DDS's own defaults announce on every interface by
// multicast; these keep a one-machine mission on 127.0.0.1, and the discovery timings
// avoid the multi-second stalls and the 20-s memory of a killed reader that the defaults give.
// DDS-Security with Fast DDS's builtin plugins: PKI-DH authentication, permissions access
// control, AES-GCM-GMAC encryption. The files are those of `keyfleet security init`
// (security_files.hpp); a mission makes them for its run. The participant's identity is the
// robot id (agents) or "station".
// On unless a config says `enabled: false`: a process without usable credentials refuses to
// start (security_files.hpp), one with security off says so at start and in its report.
struct DdsSecurity {
  bool enabled = true;
  // This host's bundle (DIR/hosts/<id> of `keyfleet security init`); relative paths from the
  // config file's folder, so by default a folder `credentials` beside the config.
  std::string directory = "credentials";
};

// A radio link between a robot and the station (or its relay), for which the DDS adapter tunes
// its transport (dds/link_tuning.hpp): user data in RTPS messages that fit the path MTU (no IP
// fragments, whose loss would lose a whole datagram), paced below the link's rate so control
// traffic is never queued behind data, reliability timing sized to the rate, and discovery that
// announces rarely and only to the configured peers. rate_kbit_s 0 = no radio link (one machine
// or a fast LAN): Fast DDS's own sizes and the max_bytes_per_s cap, if any, apply.
struct DdsLinkProfile {
  double rate_kbit_s = 0;  // the link's rate in each direction, kbit/s (1 kbit = 1000 bit)
  int mtu_bytes = 1500;    // path MTU (IP packet size) of the link
  // Share of the rate the robot's data writers may take, their IP/UDP and link headers
  // included; the rest is left to heartbeats, acknowledgements and discovery.
  double pacing = 0.9;
  double announcement_period_s = 5.0;  // participant announcements on the link
  double lease_duration_s = 20.0;      // a peer silent this long is dropped
  // A robot without a station this long joins again as a new participant (0 = never): over a
  // lossy link Fast DDS 2.9.1 can leave a DDS-Security handshake half done for good.
  double rejoin_after_s = 60.0;
};

struct DdsSettings {
  enum class Transport {
    kLocalhost,  // UDPv4 on 127.0.0.1 only, no multicast: one-machine missions and tests
    kNetwork,    // Fast DDS's built-in transports on all interfaces, plus initial_peers
  };
  int domain_id = 0;                   // 0..232; overridden by --domain / KEYFLEET_DOMAIN
  std::string partition = "keyfleet";  // overridden by --partition / KEYFLEET_PARTITION
  Transport transport = Transport::kLocalhost;
  std::vector<std::string> initial_peers;  // kNetwork: IPv4 addresses of other hosts
  // Also shared memory with peers Fast DDS takes for the same host. Unset: off with kLocalhost,
  // on with kNetwork. A process killed and restarted finds the shared-memory port it left a
  // "zombie" and resets it, while its peers go on writing into the old one: it can receive
  // nothing (Fast DDS issues #2811, #5053). A one-machine mission, all on one host, does without.
  // kNetwork with false: UDPv4 only, on the non-loopback interfaces, so that processes in
  // separate network namespaces really use their links.
  std::optional<bool> shared_memory;
  double lease_duration_s = 4.0;       // a silent peer is dropped after this long
  double announcement_period_s = 1.0;  // participant announcements
  int keyframe_history_depth = 5;      // KEEP_LAST depth of the keyframe writer
  double heartbeat_period_s = 0.1;     // reliable writer heartbeat
  // Keyframe writer's byte-rate cap (asynchronous publish through a FIFO flow controller,
  // 10 ms periods); 0 = unlimited. When capped, a full writer refuses a keyframe at once
  // and the outbox sends it again later.
  std::uint64_t max_bytes_per_s = 0;
  DdsLinkProfile link;  // rate_kbit_s > 0 overrides max_bytes_per_s, the periods and heartbeat
  DdsSecurity security;
};

// What the station accepts from a robot, checked before any image is decoded. Each knob has a
// default and a hard cap (kCap...) that the config loader enforces, so that no setting makes a
// single sample arbitrarily expensive.
struct StationLimits {
  static constexpr std::uint64_t kCapImageBytes = 64ULL << 20;
  static constexpr std::uint32_t kCapSide = 8192;
  static constexpr std::uint64_t kCapPixels = 32ULL << 20;
  static constexpr int kCapScans = 64;
  static constexpr double kCapPixelsPerByte = 10000;
  static constexpr int kCapRobots = 1024;

  std::uint64_t max_image_bytes = 8ULL << 20;  // larger samples are rejected
  std::uint32_t max_width = 4096;              // claimed or JPEG-header dimensions above these
  std::uint32_t max_height = 4096;             //   are rejected before decoding
  std::uint64_t max_pixels = 4096ULL * 3072;   // width x height at most (12.6 MP)
  // JPEG scans (SOS markers) at most: a baseline JPEG has 1 (3 when not interleaved), a
  // progressive one about 10; each scan is another pass of the decoder over the image.
  int max_scans = 16;
  // Decompression-bomb bound: pixels per compressed byte at most. A photo is 2-20, a uniform
  // baseline image below 200; only a crafted stream (e.g. progressive end-of-band runs) asks
  // for thousands of pixels per byte.
  double max_pixels_per_byte = 1000;
  // A keyframe's text regions beyond this many are ignored (the image is still stored).
  int max_text_regions = 64;
  // Robots served: only these ids (empty = any authenticated robot), and at most max_robots of
  // them, first come first served. A refused robot's topics are not read, its samples are
  // rejected, and nothing is stored for it.
  std::vector<std::string> allowed_robots;
  int max_robots = 64;
};

bool is_valid_robot_id(const std::string& robot_id);

}  // namespace keyfleet
