// Classifies captured frames by their RTPS submessages. Layouts: RTPS 2.x (DDSI-RTPS 2.3,
// section 8.3 and 9.4) and DDS-Security 1.1 (section 7.3.6), with the entity ids and the
// AES-GCM-GMAC transform's wire layout as Fast DDS 2.9.1 writes them.
#include "keyfleet/mission/rtps_accounting.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "keyfleet/common/error.hpp"

namespace keyfleet::mission {
namespace {

// Submessage ids.
constexpr std::uint8_t kPad = 0x01;
constexpr std::uint8_t kAckNack = 0x06;
constexpr std::uint8_t kHeartbeat = 0x07;
constexpr std::uint8_t kGap = 0x08;
constexpr std::uint8_t kInfoTs = 0x09;
constexpr std::uint8_t kNackFrag = 0x12;
constexpr std::uint8_t kHeartbeatFrag = 0x13;
constexpr std::uint8_t kData = 0x15;
constexpr std::uint8_t kDataFrag = 0x16;
constexpr std::uint8_t kSecBody = 0x30;

// Submessage flags.
constexpr std::uint8_t kLittleEndianFlag = 0x01;
constexpr std::uint8_t kInlineQosFlag = 0x02;
constexpr std::uint8_t kDataFlag = 0x04;  // DATA only (in DATA_FRAG 0x04 is the key flag)
constexpr std::uint8_t kKeyFlag = 0x08;   // DATA only

constexpr std::uint16_t kPidSentinel = 0x0001;
constexpr std::size_t kEthernetHeader = 14;
constexpr std::size_t kRtpsHeader = 20;
constexpr std::uint8_t kUdp = 17;

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] << 8 | p[1]); }
std::uint32_t be32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} << 24 | std::uint32_t{p[1]} << 16 | std::uint32_t{p[2]} << 8 | p[3];
}
std::uint16_t u16(const std::uint8_t* p, bool little) {
  return little ? static_cast<std::uint16_t>(p[1] << 8 | p[0]) : be16(p);
}
std::uint32_t u32(const std::uint8_t* p, bool little) {
  return little ? std::uint32_t{p[3]} << 24 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[1]} << 8 |
                      p[0]
                : be32(p);
}

// Builtin entities (EntityId_t.hpp of Fast DDS 2.9.1); anything else builtin is not classified.
std::optional<WireCategory> builtin_category(std::uint32_t entity) {
  switch (entity) {
    case 0x000100c2:
    case 0x000100c7:  // SPDP
    case 0x000002c2:
    case 0x000002c7:  // SEDP topics
    case 0x000003c2:
    case 0x000003c7:  // SEDP publications
    case 0x000004c2:
    case 0x000004c7:  // SEDP subscriptions
    case 0x000200c2:
    case 0x000200c7:  // participant message (liveliness)
    case 0x000300c3:
    case 0x000300c4:  // type lookup requests
    case 0x000301c3:
    case 0x000301c4:  // type lookup replies
    case 0xff0003c2:
    case 0xff0003c7:  // secure SEDP publications
    case 0xff0004c2:
    case 0xff0004c7:  // secure SEDP subscriptions
    case 0xff0200c2:
    case 0xff0200c7:  // secure participant message
    case 0xff0101c2:
    case 0xff0101c7:  // secure SPDP
    case 0x00030073:
    case 0x00030074:  // Fast DDS discovery server's virtual endpoints
      return WireCategory::discovery;
    case 0x000201c3:
    case 0x000201c4:  // participant stateless message (authentication)
    case 0xff0202c3:
    case 0xff0202c4:  // participant volatile message secure (key exchange)
      return WireCategory::security;
    default: return std::nullopt;
  }
}

// The two top bits of the kind: 00 user-defined, 11 builtin, 01 vendor-specific.
bool is_user_entity(std::uint32_t entity) { return entity != 0 && (entity & 0xc0) == 0; }

// Fresh parts of [lo, hi) against the runs already sent, which then cover [lo, hi) too.
std::vector<std::pair<std::uint64_t, std::uint64_t>> add_run(
    std::map<std::uint64_t, std::uint64_t>& runs, std::uint64_t lo, std::uint64_t hi) {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> fresh;
  auto it = runs.upper_bound(lo);
  if (it != runs.begin() && std::prev(it)->second >= lo) it = std::prev(it);
  std::uint64_t covered_to = lo, merged_lo = lo, merged_hi = hi;
  while (it != runs.end() && it->first <= hi) {  // overlapping or touching runs merge
    if (it->first > covered_to) fresh.emplace_back(covered_to, it->first);
    covered_to = std::max(covered_to, it->second);
    merged_lo = std::min(merged_lo, it->first);
    merged_hi = std::max(merged_hi, it->second);
    it = runs.erase(it);
  }
  if (covered_to < hi) fresh.emplace_back(covered_to, hi);
  runs[merged_lo] = merged_hi;
  return fresh;
}

// |a - b| without overflow, whatever times a capture holds.
std::uint64_t apart(std::int64_t a, std::int64_t b) {
  const auto ua = static_cast<std::uint64_t>(a), ub = static_cast<std::uint64_t>(b);
  return a > b ? ua - ub : ub - ua;
}

void add_count(DirectionAccount& direction, WireCategory category, std::uint32_t wire_bytes) {
  auto& count = direction.by_category[static_cast<std::size_t>(category)];
  count.bytes += wire_bytes;
  count.packets += 1;
}

constexpr std::array<WireCategory, kWireCategoryCount> kAllCategories = {
    WireCategory::keyframe_data, WireCategory::keyframe_repair, WireCategory::reliability_control,
    WireCategory::discovery,     WireCategory::security,        WireCategory::other_topics,
    WireCategory::unknown};

}  // namespace

std::string_view category_name(WireCategory category) {
  switch (category) {
    case WireCategory::keyframe_data: return "keyframe_data";
    case WireCategory::keyframe_repair: return "keyframe_repair";
    case WireCategory::reliability_control: return "reliability_control";
    case WireCategory::discovery: return "discovery";
    case WireCategory::security: return "security";
    case WireCategory::other_topics: return "other_topics";
    case WireCategory::unknown: return "unknown";
  }
  return "unknown";
}

TrafficCount DirectionAccount::total() const {
  TrafficCount sum;
  for (const auto& c : by_category) {
    sum.bytes += c.bytes;
    sum.packets += c.packets;
  }
  return sum;
}

// One RTPS message: `visible` bytes captured of `declared` (the UDP payload's length).
struct WireAccountant::Message {
  const std::uint8_t* data = nullptr;
  std::size_t visible = 0;
  std::size_t declared = 0;
  bool from_drone = false;
  std::array<std::uint8_t, 12> guid_prefix{};
};

WireAccountant::WireAccountant(std::set<std::uint32_t> keyframe_writer_entities,
                               WireAccountingOptions options)
    : keyframe_writers_(std::move(keyframe_writer_entities)), options_(options) {
  if (options_.busy_gap_threshold_ns < 0)
    throw StartupError("wire accounting: busy_gap_threshold_ns must not be negative");
  if (options_.fragment_tie_ns < 0)
    throw StartupError("wire accounting: fragment_tie_ns must not be negative");
  if (options_.quiet_window && options_.quiet_window->to_ns <= options_.quiet_window->from_ns)
    throw StartupError("wire accounting: the quiet window must end after it starts");
  account_.quiet_window = options_.quiet_window;
}

std::optional<WireCategory> WireAccountant::add(const CapturedPacket& packet) {
  if (const auto& w = options_.quiet_window;
      w && packet.time_ns >= w->from_ns && packet.time_ns < w->to_ns)
    (packet.from_drone ? quiet_tx_bytes_ : quiet_rx_bytes_) += packet.wire_bytes;

  const auto& b = packet.bytes;
  const auto book_now = [&](WireCategory c) {
    book(packet.time_ns, packet.from_drone, packet.wire_bytes, c);
    return c;
  };
  // Ethernet II carrying IPv4 with at least its fixed header captured.
  if (b.size() < kEthernetHeader + 20 || be16(&b[12]) != 0x0800)
    return book_now(WireCategory::unknown);
  const std::uint8_t* ip = &b[kEthernetHeader];
  const std::size_t header_bytes = std::size_t{ip[0] & 0x0fu} * 4;
  const std::size_t total_bytes = be16(ip + 2);
  if ((ip[0] >> 4) != 4 || header_bytes < 20 || total_bytes < header_bytes)
    return book_now(WireCategory::unknown);
  const bool more_fragments = (ip[6] & 0x20) != 0;
  const std::uint16_t fragment_offset = be16(ip + 6) & 0x1fff;
  const DatagramKey key{be32(ip + 12), be32(ip + 16), ip[9], be16(ip + 4)};
  const auto tie = static_cast<std::uint64_t>(options_.fragment_tie_ns);

  if (fragment_offset != 0) {
    const auto first = first_fragments_.find(key);
    if (first != first_fragments_.end() && apart(packet.time_ns, first->second.time_ns) <= tie)
      return book_now(first->second.category);
    held_fragments_[key].push_back({packet.time_ns, packet.from_drone, packet.wire_bytes});
    return std::nullopt;
  }

  const WireCategory category = ip[9] == kUdp
                                    ? classify_datagram(packet, kEthernetHeader + header_bytes,
                                                        total_bytes - header_bytes, more_fragments)
                                    : WireCategory::unknown;
  book_now(category);
  if (more_fragments) {
    first_fragments_[key] = {category, packet.time_ns};
    // Fragments that overtook this one; those too far from it in time stay held.
    if (auto held = held_fragments_.find(key); held != held_fragments_.end()) {
      std::vector<Fragment> still_held;
      for (const Fragment& f : held->second) {
        if (apart(f.time_ns, packet.time_ns) <= tie)
          book(f.time_ns, f.from_drone, f.wire_bytes, category);
        else
          still_held.push_back(f);
      }
      if (still_held.empty())
        held_fragments_.erase(held);
      else
        held->second = std::move(still_held);
    }
  }
  return category;
}

WireCategory WireAccountant::classify_datagram(const CapturedPacket& packet, std::size_t udp_offset,
                                               std::size_t ip_payload_bytes, bool more_fragments) {
  const auto& b = packet.bytes;
  if (b.size() < udp_offset + 8 || ip_payload_bytes < 8) return WireCategory::unknown;
  const std::size_t udp_bytes = be16(&b[udp_offset + 4]);
  if (udp_bytes < 8) return WireCategory::unknown;
  // A first fragment holds only part of the datagram: then the UDP length is all there is.
  std::size_t declared = udp_bytes - 8;
  if (!more_fragments) declared = std::min(declared, ip_payload_bytes - 8);

  Message message;
  message.data = b.data() + udp_offset + 8;
  message.declared = declared;
  message.visible = std::min({declared, b.size() - (udp_offset + 8), ip_payload_bytes - 8});
  message.from_drone = packet.from_drone;
  if (message.visible < kRtpsHeader || !std::equal(message.data, message.data + 4, "RTPS"))
    return WireCategory::unknown;
  std::copy(message.data + 8, message.data + 20, message.guid_prefix.begin());

  // DATA and DATA_FRAG outrank the rest (a GAP or HEARTBEAT grouped with a sample); otherwise
  // the first classifying submessage names the packet.
  std::optional<WireCategory> first_data;
  std::optional<WireCategory> first_other;
  std::size_t offset = kRtpsHeader;
  while (offset + 4 <= message.visible) {
    const std::uint8_t id = message.data[offset];
    const bool little = (message.data[offset + 1] & kLittleEndianFlag) != 0;
    const std::size_t length = u16(message.data + offset + 2, little);
    // Zero: the submessage runs to the end of the message, except PAD and INFO_TS, which
    // may be empty.
    const bool to_end = length == 0 && id != kPad && id != kInfoTs;
    const std::size_t body_end = to_end ? message.declared : offset + 4 + length;
    if (body_end > message.declared) break;  // a length that lies about the message
    // Every keyframe submessage is booked (payload, repairs), not only the one that counts.
    const auto category = classify_submessage(message, offset, body_end);
    auto& first = id == kData || id == kDataFrag ? first_data : first_other;
    if (!first) first = category;
    if (to_end || body_end > message.visible) break;
    offset = body_end;
  }
  if (first_data) return *first_data;
  return first_other.value_or(WireCategory::unknown);
}

std::optional<WireCategory> WireAccountant::classify_submessage(const Message& message,
                                                                std::size_t offset,
                                                                std::size_t body_end) {
  const std::uint8_t* s = message.data + offset;
  const std::uint8_t id = s[0];
  const std::uint8_t flags = s[1];
  const bool little = (flags & kLittleEndianFlag) != 0;
  // Fields must lie inside both the submessage and the captured bytes.
  const std::size_t available = std::min(body_end, message.visible) - offset;
  const auto has = [&](std::size_t end) { return end <= available; };

  switch (id) {
    case kHeartbeat:
    case kHeartbeatFrag:
    case kAckNack:
    case kNackFrag:
    case kGap: {
      // readerId, writerId first in each; builtin heartbeats often leave readerId unknown.
      if (!has(12)) return std::nullopt;
      const std::uint32_t reader = be32(s + 4);
      const std::uint32_t writer = be32(s + 8);
      const std::uint32_t entity = writer != 0 ? writer : reader;
      if (is_user_entity(entity)) return WireCategory::reliability_control;
      return builtin_category(entity);
    }
    case kData:
    case kDataFrag: break;
    case kSecBody: return WireCategory::security;  // encrypted: its entity cannot be seen
    default: return std::nullopt;  // INFO_*, PAD, security prefixes and postfixes, vendor ids
  }

  // DATA and DATA_FRAG: extraFlags(2) octetsToInlineQos(2) readerId(4) writerId(4) writerSN(8).
  if (!has(16)) return std::nullopt;
  const std::uint32_t writer = be32(s + 12);
  if (!is_user_entity(writer)) return builtin_category(writer);
  if (keyframe_writers_.count(writer) == 0 ||
      (options_.keyframe_from_drone_only && !message.from_drone))
    return WireCategory::other_topics;

  if (!has(24)) {  // the sequence number is cut off: neither repair nor payload can be told
    ++account_.unmeasured_payloads;
    return WireCategory::keyframe_data;
  }
  const std::int64_t sequence = static_cast<std::int64_t>(
      static_cast<std::uint64_t>(u32(s + 16, little)) << 32 | u32(s + 20, little));
  const SampleKey sample{message.from_drone, message.guid_prefix, writer, sequence};

  if (id == kDataFrag) {
    // fragmentStartingNum(4) fragmentsInSubmessage(2) fragmentSize(2) sampleSize(4).
    if (!has(36)) {
      ++account_.unmeasured_payloads;
      return WireCategory::keyframe_data;
    }
    const std::uint64_t first = u32(s + 24, little);
    const std::uint64_t count = u16(s + 28, little);
    const std::uint64_t fragment_size = u16(s + 30, little);
    const std::uint64_t sample_size = u32(s + 32, little);
    if (first == 0 || count == 0 || fragment_size == 0) {  // not a valid fragment range
      ++account_.unmeasured_payloads;
      return WireCategory::keyframe_data;
    }
    return keyframe_sample(sample, first, count, fragment_size, sample_size);
  }

  // DATA: the serialized payload follows the inline QoS (a parameter list up to its
  // sentinel) and runs to the end of the submessage.
  std::optional<std::uint64_t> payload;
  if ((flags & (kDataFlag | kKeyFlag)) == 0) {
    payload = 0;  // a dispose or unregister carries no payload
  } else {
    std::size_t at = 8 + std::size_t{u16(s + 6, little)};
    bool walked = true;
    if (flags & kInlineQosFlag) {
      walked = false;
      while (has(at + 4)) {
        const std::uint16_t pid = u16(s + at, little);
        const std::size_t parameter_length = u16(s + at + 2, little);
        at += 4;
        if (pid == kPidSentinel) {
          walked = true;
          break;
        }
        at += parameter_length;
      }
    }
    const std::size_t submessage_bytes = body_end - offset;
    if (walked && at <= submessage_bytes) payload = submessage_bytes - at;
  }
  if (!payload) ++account_.unmeasured_payloads;
  // A DATA is one fragment that is the whole sample.
  return keyframe_sample(sample, 1, 1, payload.value_or(0), payload.value_or(0));
}

WireCategory WireAccountant::keyframe_sample(const SampleKey& sample, std::uint64_t first_fragment,
                                             std::uint64_t fragments, std::uint64_t fragment_size,
                                             std::uint64_t sample_size) {
  auto [runs, new_sample] = samples_seen_.try_emplace(sample);
  if (new_sample) ++account_.keyframe_samples;
  const auto fresh = add_run(runs->second, first_fragment, first_fragment + fragments);
  if (fresh.empty()) return WireCategory::keyframe_repair;
  for (const auto& [lo, hi] : fresh) {
    // Fragment n (from 1) holds bytes [(n - 1) * size, n * size) of the sample, clipped.
    const std::uint64_t from = std::min((lo - 1) * fragment_size, sample_size);
    const std::uint64_t to = std::min((hi - 1) * fragment_size, sample_size);
    account_.keyframe_payload_bytes += to - from;
  }
  return WireCategory::keyframe_data;
}

void WireAccountant::book(std::int64_t time_ns, bool from_drone, std::uint32_t wire_bytes,
                          WireCategory category) {
  add_count(from_drone ? account_.tx : account_.rx, category, wire_bytes);
  if (category == WireCategory::keyframe_data) {
    account_.keyframe_first_ns = std::min(account_.keyframe_first_ns.value_or(time_ns), time_ns);
    account_.keyframe_last_ns = std::max(account_.keyframe_last_ns.value_or(time_ns), time_ns);
  }
  if (category == WireCategory::keyframe_data || category == WireCategory::keyframe_repair)
    keyframe_times_.push_back(time_ns);
}

WireAccount WireAccountant::account() const {
  WireAccount out = account_;
  for (const auto& [key, fragments] : held_fragments_)
    for (const auto& f : fragments)
      add_count(f.from_drone ? out.tx : out.rx, WireCategory::unknown, f.wire_bytes);

  std::vector<std::int64_t> times = keyframe_times_;
  std::sort(times.begin(), times.end());
  const auto threshold = static_cast<std::uint64_t>(options_.busy_gap_threshold_ns);
  const auto joined = [&](std::size_t i) { return apart(times[i + 1], times[i]) < threshold; };
  std::uint64_t within_sum = 0;
  std::uint64_t within_count = 0;
  for (std::size_t i = 0; i + 1 < times.size(); ++i) {
    if (!joined(i)) continue;
    within_sum += apart(times[i + 1], times[i]);
    ++within_count;
  }
  const std::uint64_t mean_gap = within_count > 0 ? within_sum / within_count : 0;
  std::uint64_t busy = 0;
  for (std::size_t i = 0; i < times.size();) {
    std::size_t j = i;
    while (j + 1 < times.size() && joined(j)) ++j;
    busy += apart(times[j], times[i]) + mean_gap;
    ++out.keyframe_bursts;
    i = j + 1;
  }
  out.keyframe_busy_ns = static_cast<std::int64_t>(busy);

  if (const auto& w = options_.quiet_window) {
    const double seconds = static_cast<double>(apart(w->to_ns, w->from_ns)) * 1e-9;
    out.quiet_tx_bytes_per_s = static_cast<double>(quiet_tx_bytes_) / seconds;
    out.quiet_rx_bytes_per_s = static_cast<double>(quiet_rx_bytes_) / seconds;
  }
  return out;
}

WireAccount account_packets(const std::vector<CapturedPacket>& packets,
                            std::set<std::uint32_t> keyframe_writer_entities,
                            WireAccountingOptions options) {
  WireAccountant accountant(std::move(keyframe_writer_entities), options);
  for (const auto& p : packets) accountant.add(p);
  return accountant.account();
}

nlohmann::json wire_account_json(const WireAccount& account) {
  using nlohmann::json;
  const auto direction = [](const DirectionAccount& d) {
    json j = json::object();
    const auto count = [](const TrafficCount& c) {
      return json{{"bytes", c.bytes}, {"packets", c.packets}};
    };
    for (const WireCategory c : kAllCategories) j[std::string(category_name(c))] = count(d[c]);
    j["total"] = count(d.total());
    return j;
  };
  const auto optional_ns = [](const std::optional<std::int64_t>& t) {
    return t ? json(*t) : json(nullptr);
  };
  json j;
  j["tx"] = direction(account.tx);
  j["rx"] = direction(account.rx);
  j["keyframe_payload_bytes"] = account.keyframe_payload_bytes;
  j["keyframe_samples"] = account.keyframe_samples;
  j["unmeasured_payloads"] = account.unmeasured_payloads;
  j["keyframe_first_ns"] = optional_ns(account.keyframe_first_ns);
  j["keyframe_last_ns"] = optional_ns(account.keyframe_last_ns);
  j["keyframe_busy_s"] = static_cast<double>(account.keyframe_busy_ns) * 1e-9;
  j["keyframe_bursts"] = account.keyframe_bursts;
  if (const auto& w = account.quiet_window) {
    j["quiet_window"] = {{"from_ns", w->from_ns},
                         {"to_ns", w->to_ns},
                         {"tx_bytes_per_s", account.quiet_tx_bytes_per_s},
                         {"rx_bytes_per_s", account.quiet_rx_bytes_per_s}};
  } else {
    j["quiet_window"] = nullptr;
  }
  return j;
}

}  // namespace keyfleet::mission
