// Links with a byte-rate cap: a capped agent delivers every keyframe without blocking and
// the station sees at most the cap; an uncapped agent beside it is faster.
#include <filesystem>

#include "keyfleet/mission/bandwidth_metrics.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::seconds;

class ShapedLink : public FleetFixture {
 protected:
  AgentConfig shaped_agent(const std::string& robot_id, std::uint64_t max_bytes_per_s) const {
    AgentConfig c = agent_config(robot_id);
    c.source.max_frames = 120;  // 24 keyframes at stride 5
    c.source.seed = 21;         // the same frames for both agents: comparable sizes
    c.dds.max_bytes_per_s = max_bytes_per_s;
    // Longer than a keyframe waits in the capped writer, so no copy is sent twice early.
    c.outbox.resend_after_s = 3.0;
    c.drain_timeout_s = 90;
    return c;
  }
};

// Serialized samples over the span of their arrival; the flow controller also counts the
// RTPS headers, so the payload rate stays under the cap: 10 % covers the clock granularity.
constexpr double kCapTolerance = 1.10;
// The uncapped agent is bound by its CPU (selection and JPEG), about 5x the cap here.
constexpr double kMinUncappedRatio = 2.0;

TEST_F(ShapedLink, CappedAgentDeliversEverythingWithinTheCapAndUncappedIsFaster) {
  constexpr std::uint64_t kCap = 40000;  // bytes/s; 24 keyframes of ~15 KB take ~9 s
  auto station = start_station(station_config());
  std::vector<std::unique_ptr<mission::ChildProcess>> agents;
  agents.push_back(start_agent(shaped_agent("capped", kCap)));
  agents.push_back(start_agent(shaped_agent("uncapped", 0)));
  finish_mission(agents, *station, seconds(150));
  if (HasFatalFailure()) return;

  const auto records = mission::read_station_records((station_dir() / "station.sqlite").string());
  const auto capped = mission::robot_metrics("capped", records.keyframes,
                                             records.agents.at("capped"), std::nullopt);
  const auto uncapped = mission::robot_metrics("uncapped", records.keyframes,
                                               records.agents.at("uncapped"), std::nullopt);
  EXPECT_EQ(capped.delivered, 24u);
  EXPECT_EQ(uncapped.delivered, 24u);
  EXPECT_EQ(outbox_pending("capped"), 0);
  EXPECT_EQ(capped.dropped, 0u);
  EXPECT_EQ(capped.payload_bytes, uncapped.payload_bytes) << "the same frames, the same bytes";

  EXPECT_LE(capped.throughput_bytes_per_s, kCap * kCapTolerance)
      << "station-side throughput above the cap";
  EXPECT_GT(uncapped.throughput_bytes_per_s, kMinUncappedRatio * capped.throughput_bytes_per_s)
      << "capped " << capped.throughput_bytes_per_s << " B/s, uncapped "
      << uncapped.throughput_bytes_per_s << " B/s";
  // The agent streamed faster than the cap: a full writer refused keyframes at once
  // (the outbox sent them later) instead of blocking the frame loop.
  EXPECT_GT(mission::count_refused_writes((agent_dir("capped") / "agent.log").string()), 0u);
  std::cout << "capped: " << capped.throughput_bytes_per_s << " B/s (cap " << kCap
            << "), uncapped: " << uncapped.throughput_bytes_per_s << " B/s, refused writes "
            << mission::count_refused_writes((agent_dir("capped") / "agent.log").string())
            << ", resent " << capped.resent << "\n";
}

}  // namespace
}  // namespace keyfleet::testing
