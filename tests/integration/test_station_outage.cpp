// The station is killed (SIGKILL) mid-mission and restarted: every keyframe published
// before, during and after the outage is stored exactly once, byte for byte.
#include <csignal>
#include <fstream>

#include <nlohmann/json.hpp>

#include "keyfleet/common/sqlite.hpp"
#include "support/expected_keyframes.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::seconds;

class StationOutage : public FleetFixture {
 protected:
  void TearDown() override {
    remove_stale_shared_memory();
    FleetFixture::TearDown();
  }
};

TEST_F(StationOutage, KeyframesPublishedWhileStationIsDownArriveOnceAfterRestart) {
  constexpr int kDrones = 3;
  std::vector<AgentConfig> configs;
  for (int i = 0; i < kDrones; ++i) {
    AgentConfig c = agent_config("drone_" + std::to_string(i));
    c.source.realtime = true;  // 240 frames at 30 fps: 8 s of flight, 40 keyframes
    c.source.max_frames = 240;
    c.selector.trigger.stride = 6;
    c.source.seed = 20 + static_cast<std::uint64_t>(i);
    configs.push_back(c);
  }
  auto station = start_station(station_config());
  std::vector<std::unique_ptr<mission::ChildProcess>> agents;
  for (const auto& c : configs) agents.push_back(start_agent(c));

  auto all_robots_have = [&](std::int64_t n) {
    const auto counts = stored_counts();
    for (const auto& c : configs) {
      const auto it = counts.find(c.robot_id);
      if (it == counts.end() || it->second < n) return false;
    }
    return true;
  };
  ASSERT_TRUE(wait_until([&] { return all_robots_have(5); }, seconds(30)))
      << "the station never stored 5 keyframes per robot";

  station->signal(SIGKILL);
  ASSERT_TRUE(station->wait_for(seconds(5)).has_value());
  const auto killed_at = Clock::now();
  const auto stored_before = stored_counts();

  // While it is down, every agent keeps keyframes unacknowledged in its outbox.
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& c : configs)
          if (outbox_pending(c.robot_id) < 3) return false;
        return true;
      },
      seconds(20)))
      << "agents did not accumulate unacknowledged keyframes during the outage";
  std::int64_t pending_at_restart = 0;
  for (const auto& c : configs) pending_at_restart += outbox_pending(c.robot_id);

  station = start_station(station_config());
  const auto restarted_at = Clock::now();
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& c : configs)
          if (outbox_pending(c.robot_id) != 0) return false;
        return true;
      },
      seconds(60)))
      << "outboxes never emptied after the restart";
  const auto recovered_at = Clock::now();

  finish_mission(agents, *station, seconds(60));

  const auto stored = stored_keyframes();
  for (const auto& c : configs) {
    const auto expected = expected_images(c);
    ASSERT_EQ(expected.size(), 40u);
    expect_stored_exactly(stored, c.robot_id, expected, 0);
  }

  std::ifstream report_file(station_dir() / "report.json");
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_GT(report["fleet"]["keyframes_resent"].get<int>(), 0);
  EXPECT_EQ(report["fleet"]["keyframes_dropped"].get<int>(), 0);

  auto ms = [](Clock::duration d) {
    return std::chrono::duration_cast<std::chrono::milliseconds>(d).count();
  };
  std::int64_t before = 0;
  for (const auto& [robot, n] : stored_before) before += n;
  std::cout << "[outage figures] stored before kill: " << before << ", station down for "
            << ms(restarted_at - killed_at) << " ms, " << pending_at_restart
            << " keyframes pending at restart, all acknowledged " << ms(recovered_at - restarted_at)
            << " ms after restart, " << report["fleet"]["keyframes_resent"].get<int>()
            << " retransmissions, " << report["fleet"]["keyframes_stored"].get<int>()
            << " stored in all\n";
}

// A robot loses its outbox (its disk was replaced) and numbers its keyframes from 0 again:
// the station already holds those numbers with other images. Nothing is overwritten or thrown
// away: the station keeps the newcomers apart as conflicts and the robot sends them again under
// new numbers, so every image of both flights is stored.
TEST_F(StationOutage, ARobotThatLostItsNumberingLosesNoKeyframe) {
  AgentConfig first = agent_config("drone_0");
  first.source.max_frames = 60;
  first.selector.trigger.stride = 6;
  first.source.seed = 31;
  AgentConfig second = first;
  second.source.seed = 32;  // other frames, the same numbers
  auto station = start_station(station_config());

  auto agent = start_agent(first);
  auto status = agent->wait_for(seconds(60));
  ASSERT_TRUE(status && status->ok()) << mission::tail_of_file(agent->log_path(), 20);
  const std::int64_t first_flight = stored_counts()["drone_0"];
  ASSERT_GT(first_flight, 3);
  std::filesystem::remove_all(agent_dir("drone_0"));

  agent = start_agent(second);
  status = agent->wait_for(seconds(60));
  ASSERT_TRUE(status && status->ok()) << mission::tail_of_file(agent->log_path(), 20);
  EXPECT_EQ(outbox_pending("drone_0"), 0);
  SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
  auto sent = db.prepare("SELECT keyframes_sent, finished FROM agent_stats WHERE robot_id=?");
  ASSERT_TRUE(sent.bind(1, std::string("drone_0")).step());
  ASSERT_EQ(sent.int64(1), 1) << "the second flight's final stats did not arrive";
  const std::int64_t second_flight = sent.int64(0);  // renumbered copies count as resends
  ASSERT_GT(second_flight, 0);
  EXPECT_EQ(stored_counts()["drone_0"], first_flight + second_flight);
  auto conflicts = db.prepare("SELECT COUNT(*) FROM conflicts WHERE robot_id='drone_0'");
  ASSERT_TRUE(conflicts.step());
  EXPECT_GE(conflicts.int64(0), std::min(first_flight, second_flight));

  station->signal(SIGTERM);
  const auto station_status = station->wait_for(seconds(30));
  ASSERT_TRUE(station_status && station_status->ok());
}

}  // namespace
}  // namespace keyfleet::testing
