#pragma once
// What the DDS adapter derives from a radio link's profile: pure arithmetic, no Fast DDS type,
// so that the numbers are testable and printable on their own.
#include <cstdint>
#include <string>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/governance.hpp"

namespace keyfleet::dds {

// IPv4 (20) and UDP (8) headers around every RTPS message.
inline constexpr std::uint32_t kIpUdpHeaderBytes = 28;
// The link layer's header per packet as a shaper counts it (Ethernet's 14 on the emulated veth
// links; a radio's MAC header is of the same order).
inline constexpr std::uint32_t kLinkHeaderBytes = 14;

struct LinkTuning {
  // The robot's data writers go through one flow controller that lets `flow_bytes_per_period`
  // bytes of RTPS messages out every `flow_period_ms`. Fast DDS also cuts a sample's fragments
  // to fit one period, so a period carries one message of at most one MTU.
  std::uint32_t flow_period_ms = 0;
  std::uint32_t flow_bytes_per_period = 0;
  std::uint32_t message_bytes = 0;   // the largest RTPS message of data this gives (UDP payload)
  std::uint32_t fragment_bytes = 0;  // the sample bytes it carries
  // false: the link is too fast for one MTU-sized message per millisecond, the shortest period:
  // each period then carries more and Fast DDS's fragments are larger than the MTU.
  bool messages_fit_mtu = true;
  double paced_wire_bytes_per_s = 0;  // the data writers' rate on the wire, headers included
  double heartbeat_period_s = 0;      // reliable writers' periodic heartbeat
  double announcement_period_s = 0;   // participant announcements
  double lease_duration_s = 0;
};

// What Fast DDS 2.9.1 (Debian's build) puts around a fragment of user data in one RTPS message,
// and what it reserves for it when it cuts a sample into fragments (RTPSWriter::
// calculateMaxDataSize: it assumes ten readers for each DDS-Security protection, more than the
// protections add with one reader and no origin authentication).
struct MessageOverhead {
  std::uint32_t added = 0;     // bytes beside the fragment in the largest data message
  std::uint32_t reserved = 0;  // bytes Fast DDS keeps free of fragment data in a message
};
// `protection`: the governance's protections, or nullopt without DDS-Security.
MessageOverhead data_message_overhead(const GovernanceProtection* protection);

// `protection`: null without DDS-Security. Throws StartupError when the profile has no rate or
// an MTU that leaves no room for data.
LinkTuning derive_link_tuning(const DdsLinkProfile& link, const GovernanceProtection* protection);

// One line for the start-up log.
std::string describe(const DdsLinkProfile& link, const LinkTuning& tuning);

}  // namespace keyfleet::dds
