// A station and three agent processes over real Fast DDS: every keyframe stored once,
// byte for byte what the agent encoded, the bandwidth report written, and the analysis' latency
// (process.json) counting each keyframe analysed once.
#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "keyfleet/common/sqlite.hpp"
#include "support/expected_keyframes.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::seconds;

class FleetEndToEnd : public FleetFixture {};

TEST_F(FleetEndToEnd, EveryKeyframeStoredExactlyOnceWithIdenticalBytes) {
  auto station = start_station(station_config());
  std::vector<AgentConfig> configs;
  std::vector<std::unique_ptr<mission::ChildProcess>> agents;
  for (int i = 0; i < 3; ++i) {
    configs.push_back(agent_config("drone_" + std::to_string(i)));
    configs.back().source.seed = 10 + static_cast<std::uint64_t>(i);
    agents.push_back(start_agent(configs.back()));
  }
  finish_mission(agents, *station, seconds(90));

  const auto stored = stored_keyframes();
  for (const auto& config : configs) {
    const auto expected = expected_images(config);
    ASSERT_EQ(expected.size(), 12u);  // 60 frames, stride 5
    expect_stored_exactly(stored, config.robot_id, expected, 5);
    EXPECT_EQ(outbox_pending(config.robot_id), 0);
  }

  std::ifstream report_file(station_dir() / "report.json");
  ASSERT_TRUE(report_file.good());
  const auto report = nlohmann::json::parse(report_file);
  EXPECT_EQ(report["fleet"]["keyframes_stored"].get<int>(), 36);
  ASSERT_EQ(report["robots"].size(), 3u);
  for (const auto& robot : report["robots"]) {
    EXPECT_TRUE(robot["agent_finished"].get<bool>()) << robot.dump();
    EXPECT_EQ(robot["frames_seen"].get<int>(), 60);
    EXPECT_GT(robot["saving_vs_stream_all"].get<double>(), 3.0) << robot.dump();
  }
  EXPECT_TRUE(std::filesystem::exists(station_dir() / "report.csv"));
  EXPECT_TRUE(std::filesystem::exists(station_dir() / "mission_log.pb"));

  // Every result the station saved had its latency counted, none twice (a stop may leave a
  // result unsaved, so the count may be above the rows, never below them nor above 36).
  const auto process = nlohmann::json::parse(read_file(station_dir() / "process.json"));
  const auto lag = process.at("analysis_latency_s");
  SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
  auto analysed =
      db.prepare("SELECT COUNT(*) FROM keyframe_analysis WHERE status IN ('done', 'failed')");
  ASSERT_TRUE(analysed.step());
  EXPECT_GE(lag.at("count").get<std::int64_t>(), analysed.int64(0)) << lag.dump();
  EXPECT_LE(lag.at("count").get<std::int64_t>(), 36) << lag.dump();
  EXPECT_LE(lag.at("p50").get<double>(), lag.at("p95").get<double>()) << lag.dump();
  EXPECT_LE(lag.at("p95").get<double>(), lag.at("max").get<double>()) << lag.dump();
  EXPECT_GE(process.at("analysis_deferred").get<int>(), 0);
}

std::set<std::string> fastdds_shm_files() {
  std::set<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator("/dev/shm"))
    if (entry.path().filename().string().rfind("fastrtps_", 0) == 0)
      names.insert(entry.path().filename().string());
  return names;
}

TEST_F(FleetEndToEnd, SignalsStopEveryProcessCleanlyWithoutStaleSharedMemory) {
  const auto shm_before = fastdds_shm_files();
  // Shared memory on (localhost leaves it off unless asked), so that there is some to leak.
  StationConfig station_settings = station_config();
  station_settings.dds.shared_memory = true;
  auto station = start_station(station_settings);
  AgentConfig config = agent_config("drone_0");
  config.dds.shared_memory = true;
  config.source.realtime = true;
  config.source.max_frames = 100000;  // would fly for an hour
  auto agent = start_agent(config);
  ASSERT_TRUE(wait_until([&] { return stored_counts()["drone_0"] >= 3; }, seconds(30)));
  auto new_shm_files = [&] {
    std::vector<std::string> names;
    for (const auto& name : fastdds_shm_files())
      if (!shm_before.count(name)) names.push_back(name);
    return names;
  };
  EXPECT_FALSE(new_shm_files().empty()) << "the processes use no shared memory";

  agent->signal(SIGINT);
  const auto agent_status = agent->wait_for(seconds(15));
  ASSERT_TRUE(agent_status.has_value()) << "agent ignored SIGINT";
  EXPECT_TRUE(agent_status->ok()) << agent_status->describe();
  station->signal(SIGTERM);
  const auto station_status = station->wait_for(seconds(15));
  ASSERT_TRUE(station_status.has_value()) << "station ignored SIGTERM";
  EXPECT_TRUE(station_status->ok()) << station_status->describe();

  const auto leaked = new_shm_files();
  EXPECT_TRUE(leaked.empty()) << "stale shared memory: " << leaked.front();
  // What the agent had not delivered when stopped stays in its outbox, not lost: every keyframe
  // it created is stored or pending. A keyframe can be both (stored, its ack not yet back when
  // the agent stopped), so the sets are compared, not their sizes.
  const std::int64_t created = outbox_created("drone_0");
  EXPECT_GE(created, 3);
  std::set<std::uint64_t> delivered_or_kept = outbox_pending_sequences("drone_0");
  for (const auto& stored : stored_keyframes()) {
    EXPECT_LT(stored.sequence_number, std::uint64_t(created)) << "stored but never created";
    delivered_or_kept.insert(stored.sequence_number);
  }
  for (std::int64_t sequence = 0; sequence < created; ++sequence)
    EXPECT_TRUE(delivered_or_kept.count(std::uint64_t(sequence)))
        << "keyframe " << sequence << " neither stored nor pending: lost";
}

}  // namespace
}  // namespace keyfleet::testing
