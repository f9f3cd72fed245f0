// Where the bytes on a drone's link go: frames built byte by byte with known answers, hostile
// frames, and pcap files written by hand.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "keyfleet/common/error.hpp"
#include "keyfleet/mission/rtps_accounting.hpp"
#include "keyfleet/mission/wire_capture.hpp"

namespace keyfleet::mission {
namespace {

using Bytes = std::vector<std::uint8_t>;
constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kSecond = 1'000'000'000;

constexpr std::uint32_t kKeyframeWriter = 0x00000103;  // "000001.03"
constexpr std::uint32_t kStatsWriter = 0x00000203;
constexpr std::uint32_t kAckReader = 0x00000207;
constexpr std::uint32_t kDroneIp = 0x0a4d0002;    // 10.77.0.2
constexpr std::uint32_t kStationIp = 0x0a4dff01;  // 10.77.255.1

void put16le(Bytes& b, std::uint16_t v) {
  b.push_back(v & 0xff);
  b.push_back(v >> 8);
}
void put32le(Bytes& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back((v >> (8 * i)) & 0xff);
}
void put16be(Bytes& b, std::uint16_t v) {
  b.push_back(v >> 8);
  b.push_back(v & 0xff);
}
void put32be(Bytes& b, std::uint32_t v) {
  for (int i = 3; i >= 0; --i) b.push_back((v >> (8 * i)) & 0xff);
}
void append(Bytes& b, const Bytes& more) { b.insert(b.end(), more.begin(), more.end()); }

// One submessage, little-endian (E flag set).
Bytes submessage(std::uint8_t id, std::uint8_t flags, const Bytes& body) {
  Bytes s{id, static_cast<std::uint8_t>(flags | 0x01)};
  put16le(s, static_cast<std::uint16_t>(body.size()));
  append(s, body);
  return s;
}

Bytes sequence_number(std::int64_t sn) {
  Bytes b;
  put32le(b, static_cast<std::uint32_t>(sn >> 32));
  put32le(b, static_cast<std::uint32_t>(sn & 0xffffffff));
  return b;
}

Bytes data_frag(std::uint32_t writer, std::int64_t sn, std::uint32_t first, std::uint16_t count,
                std::uint16_t fragment_size, std::uint32_t sample_size,
                std::size_t fragment_bytes = 64) {
  Bytes body{0, 0};
  put16le(body, 28);          // octetsToInlineQos: from here to the fragments
  put32be(body, 0x00000000);  // readerId unknown
  put32be(body, writer);
  append(body, sequence_number(sn));
  put32le(body, first);
  put16le(body, count);
  put16le(body, fragment_size);
  put32le(body, sample_size);
  body.resize(body.size() + fragment_bytes, 0xab);  // a capture would cut these anyway
  return submessage(0x16, 0, body);
}

// DATA with the data flag, optionally with inline QoS, and `payload` serialized bytes.
Bytes data(std::uint32_t writer, std::int64_t sn, std::size_t payload, bool inline_qos = false,
           bool data_flag = true) {
  Bytes body{0, 0};
  put16le(body, 16);
  put32be(body, 0);
  put32be(body, writer);
  append(body, sequence_number(sn));
  if (inline_qos) {
    put16le(body, 0x0070);  // PID_KEY_HASH, 16 bytes
    put16le(body, 16);
    body.resize(body.size() + 16, 0x11);
    put16le(body, 0x0001);  // PID_SENTINEL
    put16le(body, 0);
  }
  body.resize(body.size() + payload, 0xcd);
  return submessage(0x15, (inline_qos ? 0x02 : 0) | (data_flag ? 0x04 : 0), body);
}

Bytes heartbeat(std::uint32_t reader, std::uint32_t writer) {
  Bytes body;
  put32be(body, reader);
  put32be(body, writer);
  append(body, sequence_number(1));
  append(body, sequence_number(5));
  put32le(body, 7);
  return submessage(0x07, 0, body);
}

Bytes acknack(std::uint32_t reader, std::uint32_t writer) {
  Bytes body;
  put32be(body, reader);
  put32be(body, writer);
  append(body, sequence_number(3));  // bitmapBase
  put32le(body, 32);                 // numBits
  put32le(body, 0x80000000);
  put32le(body, 4);  // count
  return submessage(0x06, 0, body);
}

Bytes gap(std::uint32_t reader, std::uint32_t writer) {
  Bytes body;
  put32be(body, reader);
  put32be(body, writer);
  append(body, sequence_number(2));
  append(body, sequence_number(3));
  put32le(body, 0);
  return submessage(0x08, 0, body);
}

Bytes info_ts() { return submessage(0x09, 0, Bytes(8, 0x22)); }

// DDS-Security as Fast DDS writes it: SEC_PREFIX with a SecureDataHeader (transformation kind,
// key id, session id, IV suffix: 20 bytes), the protected submessage in clear (SIGN) or a
// SEC_BODY (ENCRYPT: 4-byte length, ciphertext), and a SEC_POSTFIX with the tag.
Bytes sec_prefix(std::uint8_t id = 0x31) {
  Bytes header{0, 0, 0, 1};  // CRYPTO_TRANSFORMATION_KIND_AES128_GMAC
  header.resize(20, 0x5a);
  return submessage(id, 0, header);
}
Bytes sec_body(std::size_t ciphertext) {
  Bytes body;
  put32be(body, static_cast<std::uint32_t>(ciphertext));
  body.resize(4 + (ciphertext + 3) / 4 * 4, 0x77);
  return submessage(0x30, 0, body);
}
Bytes sec_postfix(std::uint8_t id = 0x32) {
  Bytes tag(16, 0x66);  // common_mac
  put32le(tag, 0);      // no receiver-specific macs
  return submessage(id, 0, tag);
}

Bytes rtps(const std::vector<Bytes>& submessages, std::uint8_t prefix_tag = 1) {
  Bytes m{'R', 'T', 'P', 'S', 2, 3, 0x01, 0x0f};
  for (int i = 0; i < 12; ++i) m.push_back(static_cast<std::uint8_t>(prefix_tag + i));
  for (const auto& s : submessages) append(m, s);
  return m;
}

struct Ip {
  std::uint32_t source = kDroneIp;
  std::uint32_t destination = kStationIp;
  std::uint8_t protocol = 17;
  std::uint16_t id = 1;
  bool more_fragments = false;
  std::uint16_t fragment_offset = 0;  // 8-byte units
  std::size_t option_bytes = 0;       // IHL = 5 + option_bytes / 4
  std::uint16_t ethertype = 0x0800;
};

// Ethernet + IPv4 (+ UDP unless a later fragment) around `payload`.
Bytes frame(const Bytes& payload, const Ip& ip = {},
            std::optional<std::uint16_t> udp_length = std::nullopt) {
  Bytes f(12, 0x02);
  put16be(f, ip.ethertype);
  const bool udp = ip.fragment_offset == 0 && ip.protocol == 17;
  const std::size_t header = 20 + ip.option_bytes;
  const std::size_t total = header + (udp ? 8 : 0) + payload.size();
  f.push_back(static_cast<std::uint8_t>(0x40 | (header / 4)));
  f.push_back(0);
  put16be(f, static_cast<std::uint16_t>(total));
  put16be(f, ip.id);
  put16be(f, static_cast<std::uint16_t>((ip.more_fragments ? 0x2000 : 0) | ip.fragment_offset));
  f.push_back(64);
  f.push_back(ip.protocol);
  put16be(f, 0);
  put32be(f, ip.source);
  put32be(f, ip.destination);
  f.resize(f.size() + ip.option_bytes, 0x01);  // NOP options
  if (udp) {
    put16be(f, 7411);
    put16be(f, 7413);
    put16be(f, udp_length.value_or(static_cast<std::uint16_t>(8 + payload.size())));
    put16be(f, 0);
  }
  append(f, payload);
  return f;
}

CapturedPacket packet(Bytes bytes, std::int64_t time_ns = 0, bool from_drone = true,
                      std::optional<std::uint32_t> wire_bytes = std::nullopt) {
  CapturedPacket p;
  p.time_ns = time_ns;
  p.from_drone = from_drone;
  p.wire_bytes = wire_bytes.value_or(static_cast<std::uint32_t>(bytes.size()));
  p.bytes = std::move(bytes);
  return p;
}

CapturedPacket from_station(Bytes payload, std::int64_t time_ns = 0) {
  Ip ip;
  ip.source = kStationIp;
  ip.destination = kDroneIp;
  return packet(frame(payload, ip), time_ns, false);
}

WireAccountant accountant(WireAccountingOptions options = {}) {
  return WireAccountant({kKeyframeWriter}, options);
}

TEST(WireAccounting, CategoryNamesAreStable) {
  EXPECT_EQ(category_name(WireCategory::keyframe_data), "keyframe_data");
  EXPECT_EQ(category_name(WireCategory::keyframe_repair), "keyframe_repair");
  EXPECT_EQ(category_name(WireCategory::reliability_control), "reliability_control");
  EXPECT_EQ(category_name(WireCategory::discovery), "discovery");
  EXPECT_EQ(category_name(WireCategory::security), "security");
  EXPECT_EQ(category_name(WireCategory::other_topics), "other_topics");
  EXPECT_EQ(category_name(WireCategory::unknown), "unknown");
}

TEST(WireAccounting, KeyframeFragmentIsDataThenRepair) {
  auto a = accountant();
  // Sample 7 of 2500 bytes in fragments of 1000: fragment 1, again, 3 (500 bytes), 1..3.
  const auto f1 = packet(frame(rtps({info_ts(), data_frag(kKeyframeWriter, 7, 1, 1, 1000, 2500)})),
                         0, true, 1100);
  EXPECT_EQ(a.add(f1), WireCategory::keyframe_data);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 1000u);
  EXPECT_EQ(a.add(f1), WireCategory::keyframe_repair);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 1000u);
  EXPECT_EQ(
      a.add(packet(frame(rtps({data_frag(kKeyframeWriter, 7, 3, 1, 1000, 2500)})), 1, true, 600)),
      WireCategory::keyframe_data);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 1500u);  // the last fragment clipped to 500
  // Fragment 2 is new in a range that repeats 1 and 3: data, and only fragment 2 is payload.
  const auto all =
      packet(frame(rtps({data_frag(kKeyframeWriter, 7, 1, 3, 1000, 2500)})), 2, true, 2600);
  EXPECT_EQ(a.add(all), WireCategory::keyframe_data);
  EXPECT_EQ(a.add(all), WireCategory::keyframe_repair);
  // Another sequence number and another writer's prefix are new samples.
  EXPECT_EQ(a.add(packet(frame(rtps({data_frag(kKeyframeWriter, 8, 1, 1, 1000, 2500)})))),
            WireCategory::keyframe_data);
  EXPECT_EQ(a.add(packet(frame(rtps({data_frag(kKeyframeWriter, 7, 1, 1, 1000, 2500)}, 40)))),
            WireCategory::keyframe_data);

  const WireAccount w = a.account();
  EXPECT_EQ(w.keyframe_payload_bytes, 2500u + 1000u + 1000u);
  EXPECT_EQ(w.keyframe_samples, 3u);
  EXPECT_EQ(w.unmeasured_payloads, 0u);
  EXPECT_EQ(w.tx[WireCategory::keyframe_data].packets, 5u);
  EXPECT_EQ(w.tx[WireCategory::keyframe_repair].packets, 2u);
  EXPECT_EQ(w.tx[WireCategory::keyframe_repair].bytes, 1100u + 2600u);
  EXPECT_EQ(w.rx.total().packets, 0u);
}

TEST(WireAccounting, BigEndianSubmessagesReadAlike) {
  // The E flag clear: every multi-byte field big-endian (entity ids always are).
  Bytes body{0, 0};
  put16be(body, 28);
  put32be(body, 0);
  put32be(body, kKeyframeWriter);
  put32be(body, 0);
  put32be(body, 3);  // writerSN 3
  put32be(body, 2);  // fragments 2 and 3
  put16be(body, 2);
  put16be(body, 1000);
  put32be(body, 2200);
  body.resize(body.size() + 64, 0);
  Bytes frag{0x16, 0x00};
  put16be(frag, static_cast<std::uint16_t>(body.size()));
  append(frag, body);
  auto a = accountant();
  EXPECT_EQ(a.add(packet(frame(rtps({frag})))), WireCategory::keyframe_data);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 1200u);  // 1000 + the last 200
  // The same fragments written little-endian are the same sample: a repair.
  EXPECT_EQ(a.add(packet(frame(rtps({data_frag(kKeyframeWriter, 3, 2, 2, 1000, 2200)})))),
            WireCategory::keyframe_repair);
}

TEST(WireAccounting, RepairsAreCountedPerDirection) {
  WireAccountingOptions options;
  options.keyframe_from_drone_only = false;
  auto a = accountant(options);
  const Bytes message = rtps({data_frag(kKeyframeWriter, 1, 1, 1, 1000, 1000)});
  EXPECT_EQ(a.add(packet(frame(message))), WireCategory::keyframe_data);
  EXPECT_EQ(a.add(from_station(message)), WireCategory::keyframe_data);
  EXPECT_EQ(a.add(from_station(message)), WireCategory::keyframe_repair);
}

TEST(WireAccounting, StationDataWithTheKeyframeIdIsAnotherTopicByDefault) {
  auto a = accountant();
  EXPECT_EQ(a.add(from_station(rtps({data(kKeyframeWriter, 1, 40)}))), WireCategory::other_topics);
  EXPECT_EQ(a.account().keyframe_samples, 0u);
}

TEST(WireAccounting, DataPayloadFollowsInlineQos) {
  auto a = accountant();
  EXPECT_EQ(a.add(packet(frame(rtps({data(kKeyframeWriter, 1, 300, true)})))),
            WireCategory::keyframe_data);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 300u);
  EXPECT_EQ(a.add(packet(frame(rtps({data(kKeyframeWriter, 2, 120)})))),
            WireCategory::keyframe_data);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 420u);
  EXPECT_EQ(a.add(packet(frame(rtps({data(kKeyframeWriter, 1, 300, true)})))),
            WireCategory::keyframe_repair);
  // No data or key flag (a dispose): a sample without payload.
  EXPECT_EQ(a.add(packet(frame(rtps({data(kKeyframeWriter, 3, 0, true, false)})))),
            WireCategory::keyframe_data);
  const WireAccount w = a.account();
  EXPECT_EQ(w.keyframe_payload_bytes, 420u);
  EXPECT_EQ(w.keyframe_samples, 3u);
  EXPECT_EQ(w.unmeasured_payloads, 0u);
}

TEST(WireAccounting, ControlBetweenUserEndpointsIsReliability) {
  auto a = accountant();
  EXPECT_EQ(a.add(packet(frame(rtps({info_ts(), heartbeat(0, kKeyframeWriter)})))),
            WireCategory::reliability_control);
  EXPECT_EQ(a.add(from_station(rtps({acknack(kAckReader, kKeyframeWriter)}))),
            WireCategory::reliability_control);
  EXPECT_EQ(a.add(packet(frame(rtps({gap(0, kStatsWriter)})))), WireCategory::reliability_control);
  // A builtin writer's heartbeat names no reader: the writer decides.
  EXPECT_EQ(a.add(packet(frame(rtps({heartbeat(0, 0x000003c2)})))), WireCategory::discovery);
  // An acknack from a builtin reader to no particular writer: the reader decides.
  EXPECT_EQ(a.add(from_station(rtps({acknack(0x000004c7, 0)}))), WireCategory::discovery);
  const WireAccount w = a.account();
  EXPECT_EQ(w.tx[WireCategory::reliability_control].packets, 2u);
  EXPECT_EQ(w.rx[WireCategory::reliability_control].packets, 1u);
  EXPECT_EQ(w.tx[WireCategory::discovery].packets, 1u);
  EXPECT_EQ(w.rx[WireCategory::discovery].packets, 1u);
}

TEST(WireAccounting, SampleWinsOverControlInTheSameMessage) {
  auto a = accountant();
  EXPECT_EQ(a.add(packet(frame(rtps(
                {data_frag(kKeyframeWriter, 1, 1, 1, 100, 100), heartbeat(0, kKeyframeWriter)})))),
            WireCategory::keyframe_data);
  EXPECT_EQ(a.add(packet(frame(rtps({gap(0, kKeyframeWriter), info_ts(),
                                     data_frag(kKeyframeWriter, 2, 1, 1, 100, 100)})))),
            WireCategory::keyframe_data);
  EXPECT_EQ(a.add(packet(frame(rtps({heartbeat(0, kKeyframeWriter), data(kStatsWriter, 1, 8)})))),
            WireCategory::other_topics);
  // Every keyframe sample of a message is booked, not only the first.
  EXPECT_EQ(
      a.add(packet(frame(rtps({data(kKeyframeWriter, 3, 10), data(kKeyframeWriter, 4, 20)})))),
      WireCategory::keyframe_data);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 100u + 100u + 10u + 20u);
}

TEST(WireAccounting, BuiltinTrafficIsDiscoveryOrSecurity) {
  auto a = accountant();
  EXPECT_EQ(a.add(packet(frame(rtps({info_ts(), data(0x000100c2, 1, 200, true)})))),
            WireCategory::discovery);  // SPDP
  EXPECT_EQ(a.add(packet(frame(rtps({data(0x000003c2, 1, 300)})))), WireCategory::discovery);
  EXPECT_EQ(a.add(packet(frame(rtps({data(0x000200c2, 1, 40)})))), WireCategory::discovery);
  EXPECT_EQ(a.add(packet(frame(rtps({data(0xff0101c2, 1, 40)})))), WireCategory::discovery);
  // The authentication handshake and the key exchange.
  EXPECT_EQ(a.add(packet(frame(rtps({data(0x000201c3, 1, 900)})))), WireCategory::security);
  EXPECT_EQ(a.add(from_station(rtps({data(0xff0202c3, 1, 400)}))), WireCategory::security);
  EXPECT_EQ(a.add(from_station(rtps({heartbeat(0, 0xff0202c3)}))), WireCategory::security);
  // Encrypted (discovery_protection_kind ENCRYPT): the entity is inside the SEC_BODY.
  EXPECT_EQ(a.add(packet(frame(rtps({info_ts(), sec_prefix(), sec_body(180), sec_postfix()})))),
            WireCategory::security);
  // Whole-message protection (SRTPS), encrypted.
  EXPECT_EQ(a.add(packet(frame(rtps({sec_prefix(0x33), sec_body(300), sec_postfix(0x34)})))),
            WireCategory::security);
  // Signed only (GMAC): the protected submessage is in clear between prefix and postfix.
  EXPECT_EQ(a.add(packet(frame(rtps({sec_prefix(), heartbeat(0, 0xff0003c2), sec_postfix()})))),
            WireCategory::discovery);
  // Not a builtin entity Fast DDS has: nothing classifies.
  EXPECT_EQ(a.add(packet(frame(rtps({data(0x000007c2, 1, 40)})))), WireCategory::unknown);
  const WireAccount w = a.account();
  EXPECT_EQ(w.tx[WireCategory::discovery].packets, 5u);
  EXPECT_EQ(w.tx[WireCategory::security].packets, 3u);
  EXPECT_EQ(w.rx[WireCategory::security].packets, 2u);
  EXPECT_EQ(w.tx[WireCategory::unknown].packets, 1u);
}

TEST(WireAccounting, SignedKeyframeFragmentIsKeyframeData) {
  // Metadata protection SIGN (a governance option): the DATA_FRAG in clear after SEC_PREFIX.
  auto a = accountant();
  const Bytes message = rtps(
      {info_ts(), sec_prefix(), data_frag(kKeyframeWriter, 5, 1, 2, 1000, 1500), sec_postfix()});
  EXPECT_EQ(a.add(packet(frame(message))), WireCategory::keyframe_data);
  EXPECT_EQ(a.add(packet(frame(message))), WireCategory::keyframe_repair);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 1500u);
}

TEST(WireAccounting, OtherWritersAreOtherTopics) {
  auto a = accountant();
  EXPECT_EQ(a.add(packet(frame(rtps({info_ts(), data(kStatsWriter, 1, 96)})))),
            WireCategory::other_topics);
  EXPECT_EQ(a.add(from_station(rtps({data(0x00000102, 4, 32)}))), WireCategory::other_topics);
  EXPECT_EQ(a.account().keyframe_samples, 0u);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 0u);
  // No keyframe writer named: the keyframes are just another topic.
  WireAccountant none({});
  EXPECT_EQ(none.add(packet(frame(rtps({data_frag(kKeyframeWriter, 1, 1, 1, 10, 10)})))),
            WireCategory::other_topics);
}

TEST(WireAccounting, DirectionsSplit) {
  const std::vector<CapturedPacket> packets = {
      packet(frame(rtps({data_frag(kKeyframeWriter, 1, 1, 1, 1000, 1000)})), 0, true, 1100),
      from_station(rtps({acknack(kAckReader, kKeyframeWriter)})),
      packet(frame(rtps({heartbeat(0, kKeyframeWriter)})), 0, true, 90),
      packet(frame(rtps({data(0x000100c2, 1, 200)})), 0, false, 300),
      packet(frame(rtps({data(0x000100c2, 2, 200)})), 0, true, 310),
  };
  const WireAccount w = account_packets(packets, {kKeyframeWriter});
  EXPECT_EQ(w.tx[WireCategory::keyframe_data].bytes, 1100u);
  EXPECT_EQ(w.tx[WireCategory::reliability_control].bytes, 90u);
  EXPECT_EQ(w.tx[WireCategory::discovery].bytes, 310u);
  EXPECT_EQ(w.tx.total().bytes, 1100u + 90u + 310u);
  EXPECT_EQ(w.tx.total().packets, 3u);
  EXPECT_EQ(w.rx[WireCategory::reliability_control].bytes, packets[1].wire_bytes);
  EXPECT_EQ(w.rx[WireCategory::discovery].bytes, 300u);
  EXPECT_EQ(w.rx[WireCategory::keyframe_data].packets, 0u);
  EXPECT_EQ(w.rx.total().packets, 2u);
}

TEST(WireAccounting, BusyTimeJoinsBurstsAndCountsALonePacket) {
  std::vector<CapturedPacket> packets;
  std::uint32_t fragment = 1;
  const auto keyframe = [&](std::int64_t t) {
    packets.push_back(
        packet(frame(rtps({data_frag(kKeyframeWriter, 1, fragment++, 1, 1000, 100'000)})), t));
  };
  keyframe(0);
  keyframe(100 * kMs);
  keyframe(200 * kMs);
  // A heartbeat inside the quiet time is not keyframe traffic.
  packets.push_back(packet(frame(rtps({heartbeat(0, kKeyframeWriter)})), 600 * kMs));
  keyframe(1000 * kMs);
  packets.push_back(packets.back());  // a repair 100 ms later
  packets.back().time_ns = 1100 * kMs;
  keyframe(3000 * kMs);  // alone

  WireAccountingOptions options;
  options.busy_gap_threshold_ns = 500 * kMs;
  const WireAccount w = account_packets(packets, {kKeyframeWriter}, options);
  // Gaps under 0.5 s: 100, 100, 100 ms: mean 100 ms. Bursts: 0-200 ms, 1.0-1.1 s, 3.0 s.
  EXPECT_EQ(w.keyframe_bursts, 3u);
  EXPECT_EQ(w.keyframe_busy_ns, (200 + 100) * kMs + (100 + 100) * kMs + (0 + 100) * kMs);
  ASSERT_TRUE(w.keyframe_first_ns && w.keyframe_last_ns);
  EXPECT_EQ(*w.keyframe_first_ns, 0);
  EXPECT_EQ(*w.keyframe_last_ns, 3000 * kMs);  // data, not the repair at 1.1 s
  EXPECT_EQ(w.tx[WireCategory::keyframe_repair].packets, 1u);

  // A looser threshold makes one burst of the first two.
  options.busy_gap_threshold_ns = 900 * kMs;
  const WireAccount loose = account_packets(packets, {kKeyframeWriter}, options);
  EXPECT_EQ(loose.keyframe_bursts, 2u);
  // Gaps 100, 100, 800, 100 ms: mean 275 ms.
  EXPECT_EQ(loose.keyframe_busy_ns, (1100 + 275) * kMs + 275 * kMs);
}

TEST(WireAccounting, NoKeyframesNoBusyTime) {
  const WireAccount w =
      account_packets({packet(frame(rtps({heartbeat(0, kKeyframeWriter)})))}, {kKeyframeWriter});
  EXPECT_EQ(w.keyframe_bursts, 0u);
  EXPECT_EQ(w.keyframe_busy_ns, 0);
  EXPECT_FALSE(w.keyframe_first_ns);
  EXPECT_FALSE(w.keyframe_last_ns);
}

TEST(WireAccounting, QuietWindowRatePerDirection) {
  const Bytes hb = rtps({heartbeat(0, 0x000200c2)});
  const std::vector<CapturedPacket> packets = {
      packet(frame(hb), 999 * kMs, true, 999),   // before the window
      packet(frame(hb), 1000 * kMs, true, 100),  // from is inclusive
      packet(frame(hb), 1200 * kMs, false, 50),  packet(frame(hb), 1500 * kMs, true, 200),
      packet(frame(hb), 2000 * kMs, true, 1000),  // to is exclusive
      packet(frame(hb), 2500 * kMs, false, 70),
  };
  WireAccountingOptions options;
  options.quiet_window = TimeWindow{kSecond, 2 * kSecond};
  const WireAccount w = account_packets(packets, {kKeyframeWriter}, options);
  EXPECT_DOUBLE_EQ(w.quiet_tx_bytes_per_s, 300.0);
  EXPECT_DOUBLE_EQ(w.quiet_rx_bytes_per_s, 50.0);
  options.quiet_window = TimeWindow{kSecond, 3 * kSecond};
  const WireAccount wide = account_packets(packets, {kKeyframeWriter}, options);
  EXPECT_DOUBLE_EQ(wide.quiet_tx_bytes_per_s, 650.0);
  EXPECT_DOUBLE_EQ(wide.quiet_rx_bytes_per_s, 60.0);
}

TEST(WireAccounting, BadOptionsThrow) {
  WireAccountingOptions options;
  options.quiet_window = TimeWindow{2 * kSecond, 2 * kSecond};
  EXPECT_THROW(WireAccountant({}, options), StartupError);
  options.quiet_window = TimeWindow{2 * kSecond, kSecond};
  EXPECT_THROW(WireAccountant({}, options), StartupError);
  options.quiet_window.reset();
  options.busy_gap_threshold_ns = -1;
  EXPECT_THROW(WireAccountant({}, options), StartupError);
}

TEST(WireAccounting, JsonNamesTheCategories) {
  WireAccountingOptions options;
  options.quiet_window = TimeWindow{0, 2 * kSecond};
  const WireAccount w = account_packets(
      {packet(frame(rtps({data_frag(kKeyframeWriter, 1, 1, 1, 1000, 1000)})), 0, true, 1100),
       from_station(rtps({acknack(kAckReader, kKeyframeWriter)}), kSecond)},
      {kKeyframeWriter}, options);
  const nlohmann::json j = wire_account_json(w);
  for (const char* name : {"keyframe_data", "keyframe_repair", "reliability_control", "discovery",
                           "security", "other_topics", "unknown", "total"}) {
    ASSERT_TRUE(j["tx"].contains(name)) << name;
    ASSERT_TRUE(j["rx"].contains(name)) << name;
  }
  EXPECT_EQ(j["tx"]["keyframe_data"]["bytes"], 1100);
  EXPECT_EQ(j["tx"]["keyframe_data"]["packets"], 1);
  EXPECT_EQ(j["rx"]["reliability_control"]["packets"], 1);
  EXPECT_EQ(j["tx"]["total"]["bytes"], 1100);
  EXPECT_EQ(j["keyframe_payload_bytes"], 1000);
  EXPECT_EQ(j["keyframe_first_ns"], 0);
  EXPECT_EQ(j["quiet_window"]["tx_bytes_per_s"], 550.0);
  EXPECT_TRUE(wire_account_json(WireAccount{})["quiet_window"].is_null());
  EXPECT_TRUE(wire_account_json(WireAccount{})["keyframe_first_ns"].is_null());
}

// A 3000-byte UDP datagram in three IP fragments: only the first has UDP and RTPS headers.
struct Fragmented {
  CapturedPacket first, second, third;
};
Fragmented fragmented(std::uint16_t ip_id, std::int64_t t) {
  Ip ip;
  ip.id = ip_id;
  ip.more_fragments = true;
  Bytes message = rtps({data_frag(kKeyframeWriter, ip_id, 1, 1, 2900, 2900, 2900)});
  const Bytes head(message.begin(), message.begin() + 1472);
  Fragmented f;
  f.first = packet(frame(head, ip, static_cast<std::uint16_t>(8 + message.size())), t, true, 1514);
  f.first.bytes.resize(256);  // snaplen
  ip.fragment_offset = 1480 / 8;
  f.second = packet(frame(Bytes(1480, 0xab), ip), t + 1, true, 1514);
  ip.more_fragments = false;
  ip.fragment_offset = 2960 / 8;
  f.third = packet(frame(Bytes(message.size() - 1472 - 1480, 0xab), ip), t + 2, true, 100);
  return f;
}

TEST(WireAccounting, IpFragmentsFollowTheirFirstFragment) {
  auto a = accountant();
  const Fragmented in_order = fragmented(10, 0);
  EXPECT_EQ(a.add(in_order.first), WireCategory::keyframe_data);
  EXPECT_EQ(a.add(in_order.second), WireCategory::keyframe_data);
  EXPECT_EQ(a.add(in_order.third), WireCategory::keyframe_data);
  // Later fragments ahead of their first one wait for it.
  const Fragmented overtaken = fragmented(11, kSecond);
  EXPECT_FALSE(a.add(overtaken.third).has_value());
  EXPECT_FALSE(a.add(overtaken.second).has_value());
  EXPECT_EQ(a.account().tx[WireCategory::unknown].packets, 2u);  // held: unknown so far
  EXPECT_EQ(a.add(overtaken.first), WireCategory::keyframe_data);
  // A fragment whose first fragment never came.
  EXPECT_FALSE(a.add(fragmented(12, 2 * kSecond).second).has_value());

  const WireAccount w = a.account();
  EXPECT_EQ(w.tx[WireCategory::keyframe_data].packets, 6u);
  EXPECT_EQ(w.tx[WireCategory::keyframe_data].bytes, 2u * (1514 + 1514 + 100));
  EXPECT_EQ(w.tx[WireCategory::unknown].packets, 1u);
  EXPECT_EQ(w.tx[WireCategory::unknown].bytes, 1514u);
  EXPECT_EQ(w.keyframe_payload_bytes, 2u * 2900);
  EXPECT_EQ(*w.keyframe_first_ns, 0);
  EXPECT_EQ(*w.keyframe_last_ns, kSecond + 2);  // a held fragment's own time
}

TEST(WireAccounting, FragmentsTooLateAreNotTied) {
  WireAccountingOptions options;
  options.fragment_tie_ns = kSecond;
  auto a = accountant(options);
  const Fragmented f = fragmented(20, 0);
  EXPECT_EQ(a.add(f.first), WireCategory::keyframe_data);
  CapturedPacket late = f.second;
  late.time_ns = 2 * kSecond;  // the IP id may have wrapped since
  EXPECT_FALSE(a.add(late).has_value());
  EXPECT_EQ(a.account().tx[WireCategory::unknown].packets, 1u);
  // A held fragment stays held when a first fragment with its IP id comes much later.
  Fragmented reused = fragmented(21, 0);
  EXPECT_FALSE(a.add(reused.second).has_value());
  reused.first.time_ns = 5 * kSecond;
  EXPECT_EQ(a.add(reused.first), WireCategory::keyframe_data);
  EXPECT_EQ(a.account().tx[WireCategory::unknown].packets, 2u);
  EXPECT_EQ(a.account().tx[WireCategory::keyframe_data].packets, 2u);
  // A fragment of another protocol's datagram is tied to that one.
  Ip tcp;
  tcp.protocol = 6;
  tcp.id = 20;
  tcp.more_fragments = true;
  EXPECT_EQ(a.add(packet(frame(Bytes(40, 0), tcp))), WireCategory::unknown);
  tcp.more_fragments = false;
  tcp.fragment_offset = 5;
  EXPECT_EQ(a.add(packet(frame(Bytes(40, 0), tcp))), WireCategory::unknown);
  EXPECT_EQ(a.account().tx[WireCategory::keyframe_data].packets, 2u);
}

TEST(WireAccounting, EveryTruncationIsUnknownOrRight) {
  const Bytes full = frame(rtps({info_ts(), data_frag(kKeyframeWriter, 9, 1, 1, 1000, 1000)}));
  // Ethernet 14, IPv4 20, UDP 8, RTPS header 20, INFO_TS 12, then the DATA_FRAG: its
  // writerId ends 16 bytes in, its fragment fields 36 bytes in.
  const std::size_t writer_end = 14 + 20 + 8 + 20 + 12 + 16;
  const std::size_t fragment_fields_end = writer_end + 20;
  for (std::size_t length = 0; length <= full.size(); ++length) {
    auto a = accountant();
    const Bytes cut(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(length));
    const auto category = a.add(packet(cut, 0, true, static_cast<std::uint32_t>(full.size())));
    const WireAccount w = a.account();
    if (length < writer_end) {
      EXPECT_EQ(category, WireCategory::unknown) << length;
    } else {
      EXPECT_EQ(category, WireCategory::keyframe_data) << length;
      EXPECT_EQ(w.keyframe_payload_bytes, length < fragment_fields_end ? 0u : 1000u) << length;
      EXPECT_EQ(w.unmeasured_payloads, length < fragment_fields_end ? 1u : 0u) << length;
    }
    EXPECT_EQ(w.tx.total().bytes, full.size()) << length;
  }
}

TEST(WireAccounting, LyingLengthsDoNotMisleadIt) {
  auto a = accountant();
  Bytes frag = data_frag(kKeyframeWriter, 1, 1, 1, 1000, 1000);
  // octetsToNextHeader past the end of the message: the submessage is not believed.
  frag[2] = 0xff;
  frag[3] = 0xff;
  EXPECT_EQ(a.add(packet(frame(rtps({frag})))), WireCategory::unknown);
  EXPECT_EQ(a.add(packet(frame(rtps({heartbeat(0, kKeyframeWriter), frag})))),
            WireCategory::reliability_control);
  // Too short for the writerId it should hold: not classified.
  Bytes shortened = data_frag(kKeyframeWriter, 2, 1, 1, 1000, 1000);
  shortened[2] = 8;
  shortened[3] = 0;
  const Bytes message = rtps({shortened});
  EXPECT_EQ(a.add(packet(frame(Bytes(message.begin(), message.begin() + 20 + 12)))),
            WireCategory::unknown);
  // Zero on a submessage that is not the last: by the spec it runs to the end of the message.
  Bytes zero = data_frag(kKeyframeWriter, 3, 1, 1, 1000, 1000);
  zero[2] = 0;
  zero[3] = 0;
  EXPECT_EQ(a.add(packet(frame(rtps({zero, heartbeat(0, 0x000003c2)})))),
            WireCategory::keyframe_data);
  // ... and on INFO_TS (invalidate flag, no body) it means empty, and the walk goes on.
  EXPECT_EQ(a.add(packet(frame(rtps({submessage(0x09, 0x02, {}), heartbeat(0, 0x000003c2)})))),
            WireCategory::discovery);
  // A UDP length longer than the IP packet is clipped to it; shorter than its header is bad.
  EXPECT_EQ(a.add(packet(frame(rtps({heartbeat(0, 0x000003c2)}), {}, 60000))),
            WireCategory::discovery);
  EXPECT_EQ(a.add(packet(frame(rtps({heartbeat(0, 0x000003c2)}), {}, 7))), WireCategory::unknown);
  // A last DATA with length zero runs to the end of the UDP payload, however long the UDP
  // length claims that is.
  WireAccountant payloads({kKeyframeWriter});
  Bytes last = data(kKeyframeWriter, 1, 100);
  last[2] = 0;
  last[3] = 0;
  EXPECT_EQ(payloads.add(packet(frame(rtps({last})))), WireCategory::keyframe_data);
  EXPECT_EQ(payloads.account().keyframe_payload_bytes, 100u);
  last = data(kKeyframeWriter, 2, 100);
  last[2] = 0;
  last[3] = 0;
  EXPECT_EQ(payloads.add(packet(frame(rtps({last}), {}, 60000))), WireCategory::keyframe_data);
  EXPECT_EQ(payloads.account().keyframe_payload_bytes, 200u);
  // A UDP length that ends the message inside the heartbeat.
  EXPECT_EQ(a.add(packet(frame(rtps({heartbeat(0, 0x000003c2)}), {}, 8 + 20 + 10))),
            WireCategory::unknown);
  // An IP total length shorter than the IP header.
  Bytes bad_total = frame(rtps({heartbeat(0, 0x000003c2)}));
  bad_total[16] = 0;
  bad_total[17] = 10;
  EXPECT_EQ(a.add(packet(bad_total)), WireCategory::unknown);
  // Not RTPS.
  Bytes not_rtps = rtps({heartbeat(0, 0x000003c2)});
  not_rtps[3] = 'X';
  EXPECT_EQ(a.add(packet(frame(not_rtps))), WireCategory::unknown);
}

TEST(WireAccounting, OtherProtocolsAndIpOptions) {
  auto a = accountant();
  const Bytes message = rtps({data_frag(kKeyframeWriter, 1, 1, 1, 1000, 1000)});
  Ip tcp;
  tcp.protocol = 6;
  EXPECT_EQ(a.add(packet(frame(message, tcp))), WireCategory::unknown);
  Ip ipv6;
  ipv6.ethertype = 0x86dd;
  EXPECT_EQ(a.add(packet(frame(message, ipv6))), WireCategory::unknown);
  Bytes version6 = frame(message);
  version6[14] = 0x65;
  EXPECT_EQ(a.add(packet(version6)), WireCategory::unknown);
  Bytes ihl4 = frame(message);
  ihl4[14] = 0x44;
  EXPECT_EQ(a.add(packet(ihl4)), WireCategory::unknown);
  // IHL 7: 8 bytes of options before the UDP header.
  Ip options;
  options.option_bytes = 8;
  EXPECT_EQ(a.add(packet(frame(message, options))), WireCategory::keyframe_data);
  // IHL 15 with the capture ending inside the options.
  options.option_bytes = 40;
  Bytes cut = frame(message, options);
  cut.resize(14 + 40);
  EXPECT_EQ(a.add(packet(cut)), WireCategory::unknown);
  EXPECT_EQ(a.account().tx[WireCategory::unknown].packets, 5u);
  EXPECT_EQ(a.account().keyframe_payload_bytes, 1000u);
}

TEST(WireAccounting, RandomDamageNeverCrashesAndBooksEveryPacket) {
  const std::vector<Bytes> valid = {
      frame(rtps({info_ts(), sec_prefix(), data_frag(kKeyframeWriter, 5, 1, 2, 1000, 1500),
                  sec_postfix(), heartbeat(0, kKeyframeWriter)})),
      frame(rtps({data(kKeyframeWriter, 1, 300, true), acknack(kAckReader, kKeyframeWriter)})),
      frame(rtps({sec_prefix(0x33), sec_body(64), sec_postfix(0x34)})),
  };
  std::mt19937 random(1234);
  auto a = accountant();
  std::uint64_t added = 0, held = 0;
  for (int i = 0; i < 30'000; ++i) {
    Bytes b = valid[random() % valid.size()];
    const int damage = 1 + static_cast<int>(random() % 6);
    for (int d = 0; d < damage; ++d) {
      const std::size_t at = random() % b.size();
      if (random() % 2)
        b[at] = static_cast<std::uint8_t>(random());
      else
        b.resize(at);
      if (b.empty()) break;
    }
    if (!a.add(packet(b, i * kMs, random() % 2 == 0, 100))) ++held;
    ++added;
  }
  const WireAccount w = a.account();
  EXPECT_EQ(w.tx.total().packets + w.rx.total().packets, added);
  EXPECT_EQ(w.tx.total().bytes + w.rx.total().bytes, 100u * added);
  EXPECT_GT(held, 0u);  // damage reached the fragment fields too
}

// pcap files by hand: the classic format, little-endian, microseconds.
void put_pcap_header(std::ofstream& out, std::uint32_t linktype = 1) {
  Bytes h;
  put32le(h, 0xa1b2c3d4);
  put16le(h, 2);
  put16le(h, 4);
  put32le(h, 0);    // thiszone
  put32le(h, 0);    // sigfigs
  put32le(h, 256);  // snaplen
  put32le(h, linktype);
  out.write(reinterpret_cast<const char*>(h.data()), static_cast<std::streamsize>(h.size()));
}
void put_pcap_record(std::ofstream& out, std::uint32_t seconds, std::uint32_t microseconds,
                     const Bytes& captured, std::uint32_t original) {
  Bytes r;
  put32le(r, seconds);
  put32le(r, microseconds);
  put32le(r, static_cast<std::uint32_t>(captured.size()));
  put32le(r, original);
  append(r, captured);
  out.write(reinterpret_cast<const char*>(r.data()), static_cast<std::streamsize>(r.size()));
}

class PcapFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("keyfleet_wire_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

TEST_F(PcapFile, ReadsDirectionTimesAndLengths) {
  const Bytes up = frame(rtps({info_ts(), data_frag(kKeyframeWriter, 1, 1, 1, 1400, 1400, 1400)}));
  const Bytes capped(up.begin(), up.begin() + 256);
  Ip down_ip;
  down_ip.source = kStationIp;
  down_ip.destination = kDroneIp;
  const Bytes down = frame(rtps({acknack(kAckReader, kKeyframeWriter)}), down_ip);
  const auto path = (dir_ / "link.pcap").string();
  {
    std::ofstream out(path, std::ios::binary);
    put_pcap_header(out);
    put_pcap_record(out, 1700000000, 250000, capped, static_cast<std::uint32_t>(up.size()));
    put_pcap_record(out, 1700000001, 7, down, static_cast<std::uint32_t>(down.size()));
  }
  const auto packets = read_pcap(path, "10.77.0.2");
  ASSERT_EQ(packets.size(), 2u);
  EXPECT_TRUE(packets[0].from_drone);
  EXPECT_EQ(packets[0].time_ns, 1700000000LL * kSecond + 250000LL * 1000);
  EXPECT_EQ(packets[0].wire_bytes, up.size());
  EXPECT_EQ(packets[0].bytes, capped);
  EXPECT_FALSE(packets[1].from_drone);
  EXPECT_EQ(packets[1].time_ns, 1700000001LL * kSecond + 7000);
  EXPECT_EQ(packets[1].wire_bytes, down.size());
  EXPECT_EQ(packets[1].bytes, down);
  // The other end's view: the station's address is the "drone" one.
  const auto flipped = read_pcap(path, "10.77.255.1");
  EXPECT_FALSE(flipped[0].from_drone);
  EXPECT_TRUE(flipped[1].from_drone);

  const WireAccount w = account_packets(packets, {kKeyframeWriter});
  EXPECT_EQ(w.tx[WireCategory::keyframe_data].bytes, up.size());
  EXPECT_EQ(w.rx[WireCategory::reliability_control].bytes, down.size());
  EXPECT_EQ(w.keyframe_payload_bytes, 1400u);
}

TEST_F(PcapFile, AFileCutShortKeepsItsWholeRecords) {
  const Bytes f = frame(rtps({heartbeat(0, 0x000003c2)}));
  const auto path = (dir_ / "cut.pcap").string();
  {
    std::ofstream out(path, std::ios::binary);
    put_pcap_header(out);
    put_pcap_record(out, 1, 0, f, static_cast<std::uint32_t>(f.size()));
    put_pcap_record(out, 2, 0, f, static_cast<std::uint32_t>(f.size()));
  }
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 10);
  EXPECT_EQ(read_pcap(path, "10.77.0.2").size(), 1u);
}

TEST_F(PcapFile, ErrorsNameTheFile) {
  const auto missing = (dir_ / "missing.pcap").string();
  try {
    read_pcap(missing, "10.77.0.2");
    FAIL() << "no error for a missing file";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const auto text = (dir_ / "notes.pcap").string();
  std::ofstream(text) << "not a capture, just some words long enough for a header\n";
  try {
    read_pcap(text, "10.77.0.2");
    FAIL() << "no error for a text file";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
  const auto cooked = (dir_ / "any.pcap").string();
  {
    std::ofstream out(cooked, std::ios::binary);
    put_pcap_header(out, 113);  // LINKTYPE_LINUX_SLL: tcpdump -i any
  }
  EXPECT_THROW(read_pcap(cooked, "10.77.0.2"), StartupError);
  EXPECT_THROW(read_pcap(text, "10.77.0"), StartupError);
}

TEST_F(PcapFile, CaptureWithoutTcpdumpSaysSo) {
  // PATH is an empty directory for this test only, whatever it throws.
  struct PathOverride {
    std::string saved;
    explicit PathOverride(const std::string& path) {
      const char* old = std::getenv("PATH");
      saved = old ? old : "";
      ::setenv("PATH", path.c_str(), 1);
    }
    ~PathOverride() { ::setenv("PATH", saved.c_str(), 1); }
  };
  const PathOverride path(dir_.string());
  try {
    WireCapture capture({{}, "lo", (dir_ / "x.pcap").string(), (dir_ / "x.log").string()});
    FAIL() << "no error without tcpdump";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("tcpdump not found"), std::string::npos) << e.what();
  }
}

// The real thing on the loopback interface: needs root (skipped otherwise) and tcpdump.
TEST_F(PcapFile, CapturesOnLoopback) {
  if (::geteuid() != 0) GTEST_SKIP() << "capturing needs root";
  const int receiver = ::socket(AF_INET, SOCK_DGRAM, 0);
  const int sender = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(receiver, 0);
  ASSERT_GE(sender, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(receiver, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  socklen_t length = sizeof address;
  ASSERT_EQ(::getsockname(receiver, reinterpret_cast<sockaddr*>(&address), &length), 0);
  const std::uint16_t port = ntohs(address.sin_port);

  std::optional<WireCapture> capture;
  try {
    capture.emplace(
        WireCaptureOptions{{}, "lo", (dir_ / "lo.pcap").string(), (dir_ / "tcpdump.log").string()});
  } catch (const StartupError& e) {
    // tcpdump there but not allowed to capture (a container without CAP_NET_RAW): skip; a
    // capture that never says it is listening fails.
    if (std::string(e.what()).find("before capturing") == std::string::npos) throw;
    GTEST_SKIP() << e.what();
  }
  const std::vector<Bytes> messages = {
      rtps({info_ts(), data_frag(kKeyframeWriter, 1, 1, 1, 1000, 1000, 1000)}),
      rtps({heartbeat(0, 0x000003c2)}),
  };
  for (const auto& m : messages)
    ASSERT_EQ(::sendto(sender, m.data(), m.size(), 0, reinterpret_cast<sockaddr*>(&address),
                       sizeof address),
              static_cast<ssize_t>(m.size()));
  // Only this test's datagrams: other processes may use the loopback too.
  const auto ours = [&] {
    std::vector<CapturedPacket> found;
    for (auto& p : read_pcap(capture->pcap_path(), "127.0.0.1"))
      if (p.bytes.size() >= 38 && (p.bytes[36] << 8 | p.bytes[37]) == port)
        found.push_back(std::move(p));
    return found;
  };
  // tcpdump stops at SIGINT without draining what the kernel still holds for it: wait until
  // the file (flushed per packet) has both datagrams, as a caller stops after its traffic.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (ours().size() < messages.size() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const ExitStatus status = capture->stop();
  EXPECT_TRUE(status.ok()) << status.describe();
  EXPECT_EQ(capture->stop().ok(), status.ok());  // idempotent
  ::close(sender);
  ::close(receiver);

  const std::vector<CapturedPacket> packets = ours();
  ASSERT_EQ(packets.size(), 2u) << "tcpdump said:\n"
                                << tail_of_file((dir_ / "tcpdump.log").string(), 5);
  EXPECT_EQ(packets[0].bytes.size(), 256u);  // the snapshot length
  EXPECT_EQ(packets[0].wire_bytes, 14 + 20 + 8 + messages[0].size());
  const WireAccount w = account_packets(packets, {kKeyframeWriter});
  EXPECT_EQ(w.tx[WireCategory::keyframe_data].packets, 1u);
  EXPECT_EQ(w.tx[WireCategory::discovery].packets, 1u);
  EXPECT_EQ(w.keyframe_payload_bytes, 1000u);
}

}  // namespace
}  // namespace keyfleet::mission
