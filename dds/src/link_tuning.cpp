#include "keyfleet/dds/link_tuning.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cmath>

#include "keyfleet/common/error.hpp"

namespace keyfleet::dds {
namespace {

// Fast DDS's flow controller period is a whole number of milliseconds.
constexpr double kShortestPeriodMs = 1.0;
// A HEARTBEAT and the ACKNACK it asks for, each in an RTPS message of its own (header, INFO_DST,
// the submessage, Debian's statistics submessage) with its IP, UDP and link headers: about 170
// bytes each way, as captured.
constexpr double kHeartbeatExchangeBytes = 170.0;
// Share of the link the periodic heartbeats of one writer and their answers may take while
// samples are unacknowledged.
constexpr double kHeartbeatShare = 0.02;
// Faster than this the reader waits for repairs longer than it needs; slower, a lost fragment
// waits too long for its NACK.
constexpr double kMinHeartbeatS = 0.05;
constexpr double kMaxHeartbeatS = 2.0;

// RTPS framing of a data fragment: message header, INFO_DST, INFO_TS and DATA_FRAG's header;
// Debian's build (FASTDDS_STATISTICS) adds a 60-byte statistics submessage to every message.
// Fast DDS also reserves room for a piggybacked HEARTBEAT, which the tuned writers do not send.
constexpr std::uint32_t kRtpsHeader = 20;
constexpr std::uint32_t kFramingAroundFragment = 16 + 12 + 36;
constexpr std::uint32_t kPiggybackHeartbeat = 32;
constexpr std::uint32_t kStatisticsSubmessage = 60;
// AES-GCM-GMAC, per Fast DDS 2.9.1's transform: a fragment encrypted with its header (20), length
// (4), tag (16), receiver-MAC count (4) and up to 3 of padding; each signed submessage's
// SEC_PREFIX and SEC_POSTFIX (48; INFO_TS, DATA_FRAG and HEARTBEAT each wrapped); a signed
// message's INFO_SRC, SRTPS_PREFIX and SRTPS_POSTFIX (72).
constexpr std::uint32_t kPayloadProtection = 47;
constexpr std::uint32_t kSubmessageProtection = 3 * 48;
constexpr std::uint32_t kMessageProtection = 72;
// What Fast DDS reserves for each protection (ten receivers' MACs of 20 bytes each included).
constexpr std::uint32_t kPayloadReserve = 259;
constexpr std::uint32_t kSubmessageReserve = 267;
constexpr std::uint32_t kMessageReserve = 267;

}  // namespace

MessageOverhead data_message_overhead(const GovernanceProtection* p) {
  MessageOverhead o;
  o.added = kRtpsHeader + kFramingAroundFragment + kStatisticsSubmessage;
  o.reserved = o.added + kPiggybackHeartbeat;
  if (p && p->payload) {
    o.added += kPayloadProtection;
    o.reserved += kPayloadReserve;
  }
  if (p && p->metadata) {
    o.added += kSubmessageProtection;
    o.reserved += kSubmessageReserve;
  }
  if (p && p->rtps) {
    o.added += kMessageProtection;
    o.reserved += kMessageReserve;
  }
  return o;
}

LinkTuning derive_link_tuning(const DdsLinkProfile& link, const GovernanceProtection* protection) {
  if (!(link.rate_kbit_s > 0))
    throw StartupError("dds.link: rate_kbit_s must be > 0 to derive a link tuning");
  const std::uint32_t mtu = static_cast<std::uint32_t>(link.mtu_bytes);
  const MessageOverhead overhead_in_message = data_message_overhead(protection);
  if (mtu < kIpUdpHeaderBytes + overhead_in_message.added + 128)
    throw StartupError("dds.link: mtu_bytes " + std::to_string(link.mtu_bytes) +
                       " leaves too little room for data after the IP, UDP, RTPS and security "
                       "headers (" +
                       std::to_string(kIpUdpHeaderBytes + overhead_in_message.added) + " bytes)");
  const double rate_bytes_per_s = link.rate_kbit_s * 1000.0 / 8.0;
  const double paced = rate_bytes_per_s * link.pacing;
  const std::uint32_t message_bytes = mtu - kIpUdpHeaderBytes;
  const double overhead = kIpUdpHeaderBytes + kLinkHeaderBytes;
  const double wire_message = message_bytes + overhead;

  LinkTuning t;
  const double period_ms = wire_message / paced * 1000.0;
  if (period_ms < kShortestPeriodMs) {
    // More than one MTU-sized message a millisecond: a period carries more, and Fast DDS's
    // fragments grow past the MTU (IP fragments: tolerable on a fast link, not a radio's).
    t.flow_period_ms = static_cast<std::uint32_t>(kShortestPeriodMs);
    t.message_bytes = static_cast<std::uint32_t>(paced * kShortestPeriodMs / 1000.0 - overhead);
    t.messages_fit_mtu = false;
  } else {
    // Round the period down and fill it with a message that keeps the rate at or under
    // `paced` (up to half the MTU smaller just above one message a millisecond).
    t.flow_period_ms = static_cast<std::uint32_t>(std::floor(period_ms));
    t.message_bytes = std::min(
        message_bytes, static_cast<std::uint32_t>(paced * t.flow_period_ms / 1000.0 - overhead));
  }
  // Fast DDS cuts fragments to the period's budget less its reserve; the message it sends is
  // smaller by the reserve's unused part, and the next fragment no longer fits the period.
  t.fragment_bytes = t.message_bytes - overhead_in_message.added;
  t.flow_bytes_per_period = t.fragment_bytes + overhead_in_message.reserved;
  t.paced_wire_bytes_per_s =
      (t.message_bytes + overhead) * 1000.0 / static_cast<double>(t.flow_period_ms);
  t.heartbeat_period_s = std::clamp(kHeartbeatExchangeBytes / (kHeartbeatShare * rate_bytes_per_s),
                                    kMinHeartbeatS, kMaxHeartbeatS);
  t.announcement_period_s = link.announcement_period_s;
  t.lease_duration_s = link.lease_duration_s;
  return t;
}

std::string describe(const DdsLinkProfile& link, const LinkTuning& t) {
  return fmt::format(
      "radio link {:g} kbit/s, MTU {}: data paced at {:.0f} B/s on the wire (an RTPS message of "
      "up to {} B with {} B of sample every {} ms{}), heartbeat {:.3g} s, announcements every {:g} "
      "s, lease {:g} s",
      link.rate_kbit_s, link.mtu_bytes, t.paced_wire_bytes_per_s, t.message_bytes, t.fragment_bytes,
      t.flow_period_ms, t.messages_fit_mtu ? "" : ", larger than the MTU: a fast link",
      t.heartbeat_period_s, t.announcement_period_s, t.lease_duration_s);
}

}  // namespace keyfleet::dds
