// The DDS settings derived from a radio link's profile, on hand-made rates and MTUs.
#include <gtest/gtest.h>

#include "keyfleet/common/error.hpp"
#include "keyfleet/dds/link_tuning.hpp"

namespace keyfleet::dds {
namespace {

DdsLinkProfile link(double kbit_s, int mtu = 1500, double pacing = 0.9) {
  DdsLinkProfile l;
  l.rate_kbit_s = kbit_s;
  l.mtu_bytes = mtu;
  l.pacing = pacing;
  return l;
}

constexpr std::uint32_t kWireHeaders = kIpUdpHeaderBytes + kLinkHeaderBytes;

TEST(LinkTuning, HalfAMegabitWithoutSecurityByHand) {
  // Paced: 500 kbit/s * 0.9 = 56,250 B/s. A full message on the wire (1472 + 42) takes 26.9 ms:
  // 26 ms periods, each filled to 56,250 * 0.026 - 42 = 1420 bytes of RTPS.
  const LinkTuning t = derive_link_tuning(link(500), nullptr);
  EXPECT_EQ(t.flow_period_ms, 26u);
  EXPECT_EQ(t.message_bytes, 1420u);
  // Around the fragment: RTPS header 20, INFO_DST 16, INFO_TS 12, DATA_FRAG 36, statistics 60;
  // Fast DDS reserves 32 more for a piggybacked heartbeat, which the tuned writer never sends.
  EXPECT_EQ(t.fragment_bytes, 1420u - 144u);
  EXPECT_EQ(t.flow_bytes_per_period, 1420u + 32u);
  EXPECT_TRUE(t.messages_fit_mtu);
  EXPECT_NEAR(t.paced_wire_bytes_per_s, (1420.0 + kWireHeaders) / 0.026, 1e-6);
  EXPECT_LE(t.paced_wire_bytes_per_s, 56250.0);
}

TEST(LinkTuning, SecurityShrinksTheFragmentAndRaisesTheBudgetByTheUnusedReserve) {
  const GovernanceProtection payload_only{};
  const LinkTuning plain = derive_link_tuning(link(500), nullptr);
  const LinkTuning secured = derive_link_tuning(link(500), &payload_only);
  EXPECT_EQ(secured.message_bytes, plain.message_bytes) << "the same message size on the wire";
  EXPECT_EQ(secured.flow_period_ms, plain.flow_period_ms);
  // AES-GCM adds 47 bytes to the fragment's message; Fast DDS reserves 259 for it.
  EXPECT_EQ(secured.fragment_bytes, plain.fragment_bytes - 47u);
  EXPECT_EQ(secured.flow_bytes_per_period, secured.fragment_bytes + 176u + 259u);

  GovernanceProtection everything;
  everything.metadata = true;
  everything.rtps = true;
  const LinkTuning heavy = derive_link_tuning(link(500), &everything);
  EXPECT_EQ(heavy.fragment_bytes, plain.fragment_bytes - 47u - 144u - 72u);
  EXPECT_EQ(heavy.flow_bytes_per_period, heavy.fragment_bytes + 176u + 259u + 267u + 267u);
}

TEST(LinkTuning, EveryRadioRateStaysUnderItsPacingAndNeverFragmentsIp) {
  const GovernanceProtection payload_only{};
  for (double kbit : {50.0, 100.0, 250.0, 500.0, 1000.0, 2000.0, 5000.0})
    for (int mtu : {576, 1280, 1400, 1500})
      for (double pacing : {0.5, 0.9, 1.0}) {
        SCOPED_TRACE(testing::Message() << kbit << " kbit/s, MTU " << mtu << ", pacing " << pacing);
        const LinkTuning t = derive_link_tuning(link(kbit, mtu, pacing), &payload_only);
        const double paced = kbit * 125.0 * pacing;
        // Periods are whole milliseconds: past one MTU-sized message a millisecond, larger ones.
        const bool one_a_ms_is_enough = (mtu + kLinkHeaderBytes) * 1000.0 >= paced;
        EXPECT_EQ(t.messages_fit_mtu, one_a_ms_is_enough);
        if (!one_a_ms_is_enough) continue;
        EXPECT_LE(t.message_bytes + kIpUdpHeaderBytes, static_cast<std::uint32_t>(mtu));
        EXPECT_LE(t.paced_wire_bytes_per_s, paced + 1e-6);
        // Rounding the period to whole milliseconds costs little at these rates.
        EXPECT_GE(t.paced_wire_bytes_per_s, 0.95 * paced);
        EXPECT_GE(t.message_bytes + kIpUdpHeaderBytes, static_cast<std::uint32_t>(mtu) / 2);
        EXPECT_GT(t.fragment_bytes, 0u);
        EXPECT_GT(t.flow_bytes_per_period, t.message_bytes) << "the reserve exceeds the headers";
      }
}

TEST(LinkTuning, AFastLinkGetsSeveralMessagesPerMillisecond) {
  const LinkTuning t = derive_link_tuning(link(100000), nullptr);  // 100 Mbit/s
  EXPECT_EQ(t.flow_period_ms, 1u);
  EXPECT_FALSE(t.messages_fit_mtu);
  EXPECT_NEAR(t.paced_wire_bytes_per_s, 100e6 / 8 * 0.9, 1.0);
}

TEST(LinkTuning, HeartbeatsTakeAboutTwoPercentOfASlowLinkAndAreBoundedOnFastOnes) {
  // A heartbeat exchange of ~170 bytes each way at 2 % of 12,500 B/s: every 0.68 s.
  EXPECT_NEAR(derive_link_tuning(link(100), nullptr).heartbeat_period_s, 0.68, 1e-9);
  EXPECT_NEAR(derive_link_tuning(link(250), nullptr).heartbeat_period_s, 0.272, 1e-9);
  EXPECT_DOUBLE_EQ(derive_link_tuning(link(10000), nullptr).heartbeat_period_s, 0.05);
  EXPECT_DOUBLE_EQ(derive_link_tuning(link(5), nullptr).heartbeat_period_s, 2.0);
}

TEST(LinkTuning, DiscoveryPeriodsComeFromTheProfile) {
  DdsLinkProfile l = link(250);
  l.announcement_period_s = 7;
  l.lease_duration_s = 31;
  const LinkTuning t = derive_link_tuning(l, nullptr);
  EXPECT_DOUBLE_EQ(t.announcement_period_s, 7);
  EXPECT_DOUBLE_EQ(t.lease_duration_s, 31);
}

TEST(LinkTuning, RefusesNoRateAndAnMtuWithoutRoomForData) {
  EXPECT_THROW(derive_link_tuning(link(0), nullptr), StartupError);
  GovernanceProtection everything;
  everything.metadata = true;
  everything.rtps = true;
  try {
    derive_link_tuning(link(500, 400), &everything);
    FAIL() << "an MTU of 400 leaves no room beside 535 bytes of headers";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("mtu_bytes 400"), std::string::npos) << e.what();
  }
}

TEST(LinkTuning, DescribeNamesTheDerivedFigures) {
  const DdsLinkProfile l = link(250);
  const std::string text = describe(l, derive_link_tuning(l, nullptr));
  EXPECT_NE(text.find("250 kbit/s"), std::string::npos) << text;
  EXPECT_NE(text.find("heartbeat"), std::string::npos) << text;
}

}  // namespace
}  // namespace keyfleet::dds
