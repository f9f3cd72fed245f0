// Faults a flying fleet meets, with real processes: an agent killed and restarted, a lossy
// radio link, a station whose disk fills up. Nothing acknowledged is lost, nothing is numbered
// twice, and the rest of the fleet does not notice.
#include <sys/mount.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/mission/bandwidth_experiment.hpp"
#include "keyfleet/mission/experiment_config.hpp"
#include "keyfleet/mission/link_shaping.hpp"
#include "support/expected_keyframes.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

namespace fs = std::filesystem;
using std::chrono::seconds;

class Faults : public FleetFixture {
 protected:
  void TearDown() override {
    remove_stale_shared_memory();
    FleetFixture::TearDown();
  }

  AgentConfig drone(int index, std::uint64_t frames) const {
    AgentConfig c = agent_config("drone_" + std::to_string(index));
    c.source.max_frames = frames;
    c.selector.trigger.stride = 6;
    c.source.seed = 40 + static_cast<std::uint64_t>(index);
    return c;
  }

  std::set<std::uint64_t> stored_sequences(const std::string& robot) const {
    std::set<std::uint64_t> out;
    for (const StoredKeyframe& k : stored_keyframes())
      if (k.robot_id == robot) out.insert(k.sequence_number);
    return out;
  }
};

// The agent is SIGKILLed mid-flight and started again on the same outbox: every keyframe it had
// made before is delivered, the new ones continue its numbering (no number used twice, no
// conflict at the station), and the other drones deliver exactly what they made.
TEST_F(Faults, AnAgentKilledMidMissionResumesWithoutLossOrReuse) {
  std::vector<AgentConfig> configs;
  for (int i = 0; i < 3; ++i) {
    configs.push_back(drone(i, 240));  // 40 keyframes each
    configs.back().source.realtime = true;
  }
  // The victim's link is capped below its keyframe rate, so keyframes wait in its outbox when
  // it is killed.
  configs[1].dds.max_bytes_per_s = 30000;
  configs[1].outbox.resend_after_s = 4.0;
  configs[1].drain_timeout_s = 120;
  const AgentConfig& victim = configs[1];
  auto station = start_station(station_config());
  std::vector<std::unique_ptr<mission::ChildProcess>> agents;
  for (const auto& c : configs) agents.push_back(start_agent(c));

  ASSERT_TRUE(wait_until(
      [&] { return stored_counts()[victim.robot_id] >= 3 && outbox_pending(victim.robot_id) >= 3; },
      seconds(40)))
      << mission::tail_of_file(agents[1]->log_path(), 20);
  agents[1]->signal(SIGKILL);
  ASSERT_TRUE(agents[1]->wait_for(seconds(5)).has_value());
  const std::int64_t made_before = outbox_created(victim.robot_id);
  const std::set<std::uint64_t> unacknowledged = outbox_pending_sequences(victim.robot_id);
  ASSERT_FALSE(unacknowledged.empty());
  ASSERT_LT(made_before, 40) << "the agent finished before it was killed";

  AgentConfig restarted = victim;  // the same folder, outbox and numbering; no cap this time
  restarted.dds.max_bytes_per_s = 0;
  agents[1] = start_agent(restarted);
  finish_mission(agents, *station, seconds(150));

  const auto stored = stored_keyframes();
  for (int i : {0, 2})
    expect_stored_exactly(stored, configs[i].robot_id, expected_images(configs[i]), 0);

  // The restarted agent replays its camera from the start: its 40 new keyframes follow the
  // made_before ones it had numbered, each image as selected.
  const auto expected = expected_images(victim);
  ASSERT_EQ(expected.size(), 40u);
  std::map<std::uint64_t, const StoredKeyframe*> by_sequence;
  for (const StoredKeyframe& k : stored)
    if (k.robot_id == victim.robot_id) by_sequence[k.sequence_number] = &k;
  const auto total = static_cast<std::uint64_t>(made_before) + 40;
  EXPECT_EQ(by_sequence.size(), total) << "made before the kill: " << made_before;
  for (std::uint64_t s = 0; s < total; ++s) {
    const auto it = by_sequence.find(s);
    ASSERT_NE(it, by_sequence.end())
        << "sequence " << s << " of " << total << " missing"
        << (unacknowledged.count(s) ? " (unacknowledged at the kill)" : "");
    const std::size_t index =
        s < static_cast<std::uint64_t>(made_before) ? s : static_cast<std::size_t>(s - made_before);
    EXPECT_EQ(it->second->image, expected[index]) << "sequence " << s;
  }
  SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
  auto conflicts = db.prepare("SELECT COUNT(*) FROM conflicts");
  ASSERT_TRUE(conflicts.step());
  EXPECT_EQ(conflicts.int64(0), 0) << "a sequence number was used twice";
  std::cout << "[agent kill figures] made before the kill: " << made_before << ", unacknowledged "
            << unacknowledged.size() << ", stored for the victim: " << by_sequence.size()
            << " (all delivered, none reused)\n";
}

// 30 % of the packets on the drone's link (both ways) are dropped by an nftables rule in its
// network namespace: every keyframe still arrives, by DDS repairs and the outbox's resends.
TEST_F(Faults, ThirtyPercentPacketLossStillDeliversEveryKeyframe) {
  if (const auto reason = mission::netns_unavailable_reason())
    GTEST_SKIP() << "needs network namespaces: " << *reason;
  if (mission::run_command({"nft", "--version"}).exit_code != 0)
    GTEST_SKIP() << "nft (Debian's nftables) is not installed";
  BandwidthExperimentConfig config;
  config.name = "loss30";
  config.run_root = run_dir_.string();
  config.drones = {1};
  config.links = {"netns"};
  LinkProfileConfig profile;
  // Lost on arrival, each IP packet alone: only MTU-sized RTPS messages (dds.link, which needs
  // the link's rate) get through; a 15 KB keyframe in one datagram of 11 IP fragments would
  // arrive whole 2 % of the time.
  profile.name = "loss30";
  profile.rate_kbit_s = 2000;
  profile.loss_percent = 30;
  config.profiles = {profile};
  config.mission.agent = drone(0, 60);  // 10 keyframes
  config.mission.agent.drain_timeout_s = 120;
  config.mission.agent_timeout_s = 180;
  config.mission.security = false;
  StationConfig station = station_config();
  station.analysis.text.enabled = false;
  station.analysis.places.enabled = false;
  config.mission.station = station;
  mission::MissionBinaries binaries{KEYFLEET_AGENT_BIN, KEYFLEET_STATION_BIN};
  std::ostringstream progress;
  StopToken stop;
  mission::BandwidthExperiment experiment(config, binaries, make_logger("loss30", "warn"),
                                          progress);
  const auto started = std::chrono::steady_clock::now();
  const auto result = experiment.run(stop);
  const auto seconds_taken =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ASSERT_EQ(result.missions.size(), 1u) << progress.str();
  const auto& run = result.missions[0];
  ASSERT_TRUE(run.ok) << progress.str();
  std::string notes;
  for (const auto& n : run.notes) notes += n + "\n";
  ASSERT_NE(notes.find("loss"), std::string::npos) << notes;
  EXPECT_EQ(notes.find("NOT applied\n"), std::string::npos) << notes;
  ASSERT_EQ(run.robots.size(), 1u);
  const auto& robot = run.robots[0].metrics;
  EXPECT_EQ(robot.delivered,
            static_cast<std::uint64_t>(expected_images(config.mission.agent).size()));
  EXPECT_EQ(robot.dropped, 0u);
  std::cout << "[loss figures] 30 % loss: " << robot.delivered << " keyframes delivered in "
            << seconds_taken << " s, " << robot.resent << " resent by the outbox, wire "
            << (robot.wire ? robot.wire->tx_bytes : 0) << " B for " << robot.payload_bytes
            << " B of keyframes\n"
            << notes;
}

// A tmpfs mounted on a folder for the length of a test; gone even when the test fails.
class SmallDisk {
 public:
  SmallDisk(const fs::path& where, const std::string& size) : where_(where) {
    fs::create_directories(where);
    const std::string options = "size=" + size + ",mode=0755";
    if (::mount("keyfleet-test", where.c_str(), "tmpfs", 0, options.c_str()) != 0)
      problem_ = std::string("mount tmpfs: ") + std::strerror(errno);
  }
  ~SmallDisk() {
    if (problem_.empty()) ::umount2(where_.c_str(), MNT_DETACH);
  }
  bool grow(const std::string& size) {
    const std::string options = "size=" + size;
    return ::mount("keyfleet-test", where_.c_str(), "tmpfs", MS_REMOUNT, options.c_str()) == 0;
  }
  const std::string& problem() const { return problem_; }

 private:
  fs::path where_;
  std::string problem_;
};

// The station's run folder is a 1.5 MB tmpfs: it fills up mid-flight. The station says so, stops
// acknowledging (the agent keeps its copies), still writes its report when stopped, and every
// keyframe it acknowledged is in its database. Given room again, it receives the rest.
TEST_F(Faults, AFullDiskLosesNothingAcknowledgedAndTheReportIsWritten) {
  if (::geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root";
  SmallDisk disk(station_dir(), "1500k");
  if (!disk.problem().empty()) GTEST_SKIP() << disk.problem();
  StationConfig station_settings = station_config();
  station_settings.analysis.text.enabled = false;
  station_settings.analysis.places.enabled = false;
  station_settings.report_reserve_bytes = 256 * 1024;
  AgentConfig agent_settings = drone(0, 240);  // 40 keyframes, about 4 MB
  agent_settings.drain_timeout_s = 300;        // it waits for the station to have room again
  const fs::path station_log = run_dir_ / "station_out.log";  // not on the small disk
  auto station = start_station(station_settings, station_log);
  std::vector<std::unique_ptr<mission::ChildProcess>> agents;
  agents.push_back(start_agent(agent_settings));

  ASSERT_TRUE(wait_until(
      [&] { return read_file(station_log).find("nothing is acknowledged") != std::string::npos; },
      seconds(60)))
      << "the station never said its storage failed:\n"
      << mission::tail_of_file(station_log.string(), 20);
  station->signal(SIGTERM);
  const auto stopped = station->wait_for(seconds(60));
  ASSERT_TRUE(stopped.has_value());
  EXPECT_TRUE(stopped->ok()) << mission::tail_of_file(station_log.string(), 20);

  // Acknowledged = made by the agent and no longer in its outbox: each one is stored.
  const std::int64_t made = outbox_created(agent_settings.robot_id);
  const std::set<std::uint64_t> pending = outbox_pending_sequences(agent_settings.robot_id);
  const std::set<std::uint64_t> stored = stored_sequences(agent_settings.robot_id);
  ASSERT_FALSE(pending.empty()) << "the disk never filled: nothing waits in the outbox";
  std::size_t acknowledged = 0;
  for (std::uint64_t s = 0; s < static_cast<std::uint64_t>(made); ++s) {
    if (pending.count(s)) continue;
    ++acknowledged;
    EXPECT_TRUE(stored.count(s)) << "keyframe " << s << " was acknowledged but is not stored";
  }
  const auto report = nlohmann::json::parse(read_file(station_dir() / "report.json"));
  EXPECT_EQ(report["fleet"]["keyframes_stored"].get<std::size_t>(), stored.size());
  EXPECT_TRUE(fs::exists(station_dir() / "report.txt"));
  const std::size_t stored_when_full = stored.size();

  ASSERT_TRUE(disk.grow("64m"));
  station = start_station(station_settings, station_log);
  finish_mission(agents, *station, seconds(120));
  expect_stored_exactly(stored_keyframes(), agent_settings.robot_id,
                        expected_images(agent_settings), 0);
  std::cout << "[full disk figures] " << made << " keyframes made, " << acknowledged
            << " acknowledged and stored before the disk filled (" << stored_when_full
            << " stored), " << pending.size()
            << " kept by the agent, all 40 stored once the disk had room\n";
}

// Two stations on one run folder would interleave one database, mission log and reports: the
// second refuses to start, naming the folder and the first's pid; the first goes on.
TEST_F(Faults, ASecondStationOnTheSameRunFolderIsRefused) {
  auto first = start_station(station_config());
  const fs::path first_log = station_dir() / "station.log";
  ASSERT_TRUE(
      wait_until([&] { return read_file(first_log).find("station ready") != std::string::npos; },
                 std::chrono::milliseconds(30000)))
      << "the first station never got ready";
  const fs::path second_log = run_dir_ / "second_station.log";
  auto second = start_station(station_config(), second_log);
  const auto status = second->wait_for(std::chrono::milliseconds(30000));
  ASSERT_TRUE(status.has_value()) << "the second station is still running";
  EXPECT_FALSE(status->ok());
  const std::string text = read_file(second_log);
  EXPECT_NE(text.find("is in use by another process (pid " + std::to_string(first->pid())),
            std::string::npos)
      << text;
  EXPECT_FALSE(first->poll().has_value()) << "the first station stopped";
  std::vector<std::unique_ptr<mission::ChildProcess>> no_agents;
  finish_mission(no_agents, *first, seconds(30));
}

}  // namespace
}  // namespace keyfleet::testing
