#pragma once
// Where the bytes on a drone's link go: each captured frame is attributed whole to one
// category (keyframe data, its repairs, reliability control, discovery, security, other topics,
// unknown) by reading its Ethernet, IPv4, UDP and RTPS headers. Pure: no I/O, so the
// arithmetic is testable on hand-made packets; the capture itself is wire_capture.hpp.
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <set>
#include <string_view>
#include <tuple>
#include <vector>

namespace keyfleet::mission {

// One frame as a capture saw it on the drone's veth.
struct CapturedPacket {
  std::int64_t time_ns = 0;
  bool from_drone = false;          // direction: drone -> station ("tx") or station -> drone ("rx")
  std::uint32_t wire_bytes = 0;     // frame length on the wire incl. Ethernet header (orig_len)
  std::vector<std::uint8_t> bytes;  // captured bytes from the Ethernet header (snaplen-truncated)
};

enum class WireCategory : std::uint8_t {
  keyframe_data,        // first transmission of a keyframe writer's DATA / DATA_FRAG
  keyframe_repair,      // a keyframe DATA / DATA_FRAG all of whose fragments were sent before
  reliability_control,  // HEARTBEAT(_FRAG), ACKNACK, NACK_FRAG, GAP of user endpoints
  discovery,            // SPDP, SEDP, liveliness (WLP), type lookup, their secure variants
  security,             // authentication handshake, key exchange, encrypted (SEC_BODY) traffic
  other_topics,         // user-topic data not from a keyframe writer (agent stats, acks)
  unknown,              // not RTPS, unparseable, or truncated before anything classifiable
};
inline constexpr std::size_t kWireCategoryCount = 7;

// Stable names for JSON and CSV ("keyframe_data", ...).
std::string_view category_name(WireCategory category);

struct TrafficCount {
  std::uint64_t bytes = 0;  // wire_bytes summed
  std::uint64_t packets = 0;
};

// One direction of the link, by category.
struct DirectionAccount {
  std::array<TrafficCount, kWireCategoryCount> by_category{};
  const TrafficCount& operator[](WireCategory c) const {
    return by_category[static_cast<std::size_t>(c)];
  }
  TrafficCount total() const;
};

struct TimeWindow {
  std::int64_t from_ns = 0;  // inclusive
  std::int64_t to_ns = 0;    // exclusive
};

struct WireAccountingOptions {
  // Keyframe packets closer than this belong to one busy interval (0.5 s).
  std::int64_t busy_gap_threshold_ns = 500'000'000;
  // Where to measure idle chatter (bytes/s per direction); nullopt: not measured.
  std::optional<TimeWindow> quiet_window;
  // A non-first IP fragment takes its first fragment's category only within this time of it
  // (Linux's ipfrag_time, 30 s): IP ids wrap, and a stale tie would be a guess.
  std::int64_t fragment_tie_ns = 30'000'000'000;
  // The station's participant numbers its entities as the drone's does, so one of its writers
  // may share a keyframe writer's entity id: by default only drone -> station data counts.
  bool keyframe_from_drone_only = true;
};

struct WireAccount {
  DirectionAccount tx;  // drone -> station
  DirectionAccount rx;  // station -> drone
  // Serialized keyframe payload sent for the first time (with data_protection ENCRYPT, the
  // encrypted payload): new DATA_FRAG fragments clipped to sampleSize, DATA payloads.
  std::uint64_t keyframe_payload_bytes = 0;
  std::uint64_t keyframe_samples = 0;  // distinct (writer, sequence number) seen
  // Keyframe submessages whose payload length the capture did not show (snaplen).
  std::uint64_t unmeasured_payloads = 0;
  std::optional<std::int64_t> keyframe_first_ns;  // first and last keyframe_data packet
  std::optional<std::int64_t> keyframe_last_ns;
  std::int64_t keyframe_busy_ns = 0;  // see WireAccountant::account()
  std::uint64_t keyframe_bursts = 0;
  std::optional<TimeWindow> quiet_window;
  double quiet_tx_bytes_per_s = 0;
  double quiet_rx_bytes_per_s = 0;
};

// Books captured packets one at a time, in capture order, and sums them up.
//
// Keyframe writers are named by the caller (entity ids such as "000001.03" -> 0x00000103);
// there is deliberately no heuristic fallback (largest writer, ...): a wrong guess would move
// bytes between categories silently, and an empty set just books all user data as
// other_topics.
//
// A packet is attributed whole to the category of its first DATA or DATA_FRAG with a known
// writer, else of its first other classifying submessage (control submessages with a known
// entity, SEC_BODY), so a sample wins over a HEARTBEAT or GAP grouped with it whatever their
// order. INFO_*, PAD and the security prefixes and postfixes do not classify, so a signed (GMAC)
// submessage is classified by the clear submessage after its SEC_PREFIX, and an encrypted one
// (SEC_BODY) is `security`, since its entity cannot be seen. With discovery and liveliness
// protection ENCRYPT (as the fleet's governance has them) that puts secure SEDP and liveliness
// under `security`; keyframe submessages stay visible as long as topic metadata protection is
// NONE or SIGN (payload protection encrypts only the serialized payload).
//
// Repairs: a keyframe DATA_FRAG is a repair when every fragment it carries was already seen
// for the same (direction, writer GUID prefix, entity, sequence number); one with any new
// fragment is data, and only its new fragments count as payload. A DATA is one fragment.
//
// IP fragments: Fast DDS's UDP datagrams may exceed the MTU (its default limit is 65500
// bytes), and then the kernel splits them: only the first fragment carries the UDP and RTPS
// headers. A later fragment takes the category of the first fragment with the same (source,
// destination, protocol, IP id) seen within fragment_tie_ns; one that arrives before its first
// fragment is held until it comes. Fragments whose first fragment never appears are booked as
// `unknown`.
//
// Never throws on packet contents and never reads outside a packet's bytes.
class WireAccountant {
 public:
  // Throws StartupError for a negative threshold or an empty or reversed quiet window.
  explicit WireAccountant(std::set<std::uint32_t> keyframe_writer_entities,
                          WireAccountingOptions options = {});

  // Classifies and books one packet; nullopt when it is an IP fragment held until its first
  // fragment appears (it is then booked under that fragment's category).
  std::optional<WireCategory> add(const CapturedPacket& packet);

  // The totals so far, held fragments as `unknown`. Busy time: keyframe data and repair
  // packets joined into bursts where consecutive packets are less than busy_gap_threshold_ns
  // apart; each burst lasts from its first to its last packet plus the mean gap within bursts
  // (so a lone packet counts too). Without any gap under the threshold there is no such mean
  // and the busy time is 0.
  WireAccount account() const;

 private:
  struct Fragment {
    std::int64_t time_ns;
    bool from_drone;
    std::uint32_t wire_bytes;
  };
  using DatagramKey = std::tuple<std::uint32_t, std::uint32_t, std::uint8_t, std::uint16_t>;
  struct FirstFragment {
    WireCategory category;
    std::int64_t time_ns;
  };
  // Fragment numbers [first, end) of one sample already sent, as disjoint runs first -> end.
  using FragmentRuns = std::map<std::uint64_t, std::uint64_t>;
  using SampleKey = std::tuple<bool, std::array<std::uint8_t, 12>, std::uint32_t, std::int64_t>;
  struct Message;

  WireCategory classify_datagram(const CapturedPacket& packet, std::size_t udp_offset,
                                 std::size_t ip_payload_bytes, bool more_fragments);
  std::optional<WireCategory> classify_submessage(const Message& message, std::size_t offset,
                                                  std::size_t body_end);
  // Books fragments [first, first + count) of a keyframe sample: data if any is new.
  WireCategory keyframe_sample(const SampleKey& sample, std::uint64_t first_fragment,
                               std::uint64_t fragments, std::uint64_t fragment_size,
                               std::uint64_t sample_size);
  void book(std::int64_t time_ns, bool from_drone, std::uint32_t wire_bytes, WireCategory category);

  std::set<std::uint32_t> keyframe_writers_;
  WireAccountingOptions options_;
  WireAccount account_;
  std::vector<std::int64_t> keyframe_times_;
  std::map<DatagramKey, FirstFragment> first_fragments_;
  std::map<DatagramKey, std::vector<Fragment>> held_fragments_;
  std::map<SampleKey, FragmentRuns> samples_seen_;
  std::uint64_t quiet_tx_bytes_ = 0;
  std::uint64_t quiet_rx_bytes_ = 0;
};

// All packets at once.
WireAccount account_packets(const std::vector<CapturedPacket>& packets,
                            std::set<std::uint32_t> keyframe_writer_entities,
                            WireAccountingOptions options = {});

// {"tx": {"keyframe_data": {"bytes", "packets"}, ..., "total": {...}}, "rx": {...},
//  "keyframe_payload_bytes", ..., "quiet_window": {"from_ns", "to_ns", "tx_bytes_per_s",
//  "rx_bytes_per_s"} or null}; absent times are null.
nlohmann::json wire_account_json(const WireAccount& account);

}  // namespace keyfleet::mission
