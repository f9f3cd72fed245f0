// The station serves its allow-list and at most max_robots robots over real DDS: a stranger's
// topics are not read, it is logged once and counted in report.json, and nothing of it is stored.
// With DDS-Security on it serves the fleet's robots only: a stranger cannot take a slot, and a
// withdrawn robot is refused by the CRL and by the roster.
#include <nlohmann/json.hpp>

#include <csignal>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::seconds;

class StationAdmission : public FleetFixture {
 protected:
  std::string station_log() const {
    std::ifstream in(station_dir() / "station.log");
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  std::size_t log_lines_mentioning(const std::string& what) const {
    std::istringstream lines(station_log());
    std::size_t count = 0;
    for (std::string line; std::getline(lines, line);)
      count += line.find(what) != std::string::npos;
    return count;
  }
  // Publishes until the station logs `line` (the link publishes into the void meanwhile).
  bool publish_until_logged(AgentLink& link, const std::string& robot, const std::string& line) {
    std::uint64_t sequence = 0;
    return wait_until(
        [&] {
          link.publish(small_keyframe(robot, sequence++));
          return log_lines_mentioning(line) > 0;
        },
        seconds(20));
  }
  nlohmann::json stop_and_read_report(mission::ChildProcess& station) {
    station.signal(SIGTERM);
    const auto status = station.wait_for(seconds(30));
    EXPECT_TRUE(status && status->ok()) << mission::tail_of_file(station.log_path(), 20);
    std::ifstream in(station_dir() / "report.json");
    return nlohmann::json::parse(in);
  }
  std::int64_t rows_for(const std::string& table, const std::string& robot) const {
    SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
    auto q = db.prepare("SELECT COUNT(*) FROM " + table + " WHERE robot_id = ?1");
    q.bind(1, robot);
    return q.step() ? q.int64(0) : -1;
  }
};

TEST_F(StationAdmission, StationServesItsAllowListOnly) {
  StationConfig config = station_config();
  config.limits.allowed_robots = {"good_drone"};
  auto station = start_station(config);
  auto good_agent = start_agent(agent_config("good_drone"));

  auto stranger = make_dds_agent_link(dds(), "stranger", null_logger());
  ASSERT_TRUE(publish_until_logged(*stranger, "stranger",
                                   "robot 'stranger' refused: not on limits.allowed_robots"))
      << station_log();

  const auto status = good_agent->wait_for(seconds(60));
  ASSERT_TRUE(status && status->ok()) << mission::tail_of_file(good_agent->log_path(), 20);
  EXPECT_EQ(stored_counts()["good_drone"], 12);
  EXPECT_EQ(stranger->matched_stations(), 0u) << "the station made a reader for the stranger";
  stranger->publish(small_keyframe("stranger", 1000));

  const nlohmann::json report = stop_and_read_report(*station);
  EXPECT_EQ(report["refused_robots"]["not_allowed"], 1) << report.dump(2);
  EXPECT_EQ(report["refused_robots"]["ids"], nlohmann::json::array({"stranger"}));
  EXPECT_EQ(log_lines_mentioning("'stranger'"), 1u) << station_log();
  EXPECT_EQ(stored_counts().count("stranger"), 0u);
  EXPECT_EQ(rows_for("rejected", "stranger"), 0);
  EXPECT_EQ(report["robots"].size(), 1u) << report.dump(2);
}

TEST_F(StationAdmission, StationServesAtMostMaxRobots) {
  StationConfig config = station_config();
  config.limits.max_robots = 1;
  auto station = start_station(config);

  auto first = make_dds_agent_link(dds(), "first", null_logger());
  ASSERT_TRUE(wait_until([&] { return first->matched_stations() > 0; }, seconds(20)));
  const auto ack = first_answer(*first, small_keyframe("first", 0), seconds(20));
  ASSERT_TRUE(ack.has_value());
  EXPECT_EQ(ack->status, AckStatus::kStored) << ack->reason;

  auto second = make_dds_agent_link(dds(), "second", null_logger());
  ASSERT_TRUE(publish_until_logged(*second, "second", "robot 'second' refused: limits.max_robots"))
      << station_log();
  EXPECT_EQ(second->matched_stations(), 0u);

  const nlohmann::json report = stop_and_read_report(*station);
  EXPECT_EQ(report["refused_robots"]["over_quota"], 1) << report.dump(2);
  EXPECT_EQ(log_lines_mentioning("'second'"), 1u) << station_log();
  EXPECT_EQ(stored_counts(), (std::map<std::string, std::int64_t>{{"first", 1}}));
}

class SecuredStationAdmission : public StationAdmission {
 protected:
  void SetUp() override {
    StationAdmission::SetUp();
    credentials_ = (run_dir_ / "security").string();
    mission::write_fleet_credentials({credentials_, {"drone_0", "drone_1", "drone_2"}},
                                     null_logger());
    // The lost robot keeps its copy of its bundle; `withdraw` deletes the fleet's.
    std::filesystem::copy(mission::host_bundle(credentials_, "drone_1"), run_dir_ / "lost_drone_1",
                          std::filesystem::copy_options::recursive);
    mission::withdraw_robot({credentials_, "drone_1"}, null_logger());
  }
  StationConfig secured_station(const std::string& bundle, int max_robots) const {
    StationConfig config = station_config();
    config.dds.security = {true, bundle};
    config.limits.max_robots = max_robots;
    return config;
  }
  AgentConfig secured_agent(const std::string& robot_id) const {
    AgentConfig config = agent_config(robot_id);
    config.dds.security = {true, mission::host_bundle(credentials_, robot_id)};
    return config;
  }
  DdsSettings with_bundle(const std::string& bundle) const {
    DdsSettings settings = dds();
    settings.security = {true, bundle};
    return settings;
  }
  std::string station_bundle() const { return mission::host_bundle(credentials_, "station"); }
  std::string credentials_;
};

// The attack of issue 31: a stranger asks for the last slot before the robot. Without an
// identity it is never authenticated, so never takes it; the robot is served. The withdrawn
// robot's own (valid, unexpired) credentials fail the station's CRL check likewise.
TEST_F(SecuredStationAdmission, StrangerAndWithdrawnRobotCannotTakeTheLastSlot) {
  auto station = start_station(secured_station(station_bundle(), 1));
  ASSERT_TRUE(wait_until([&] { return log_lines_mentioning("station ready") > 0; }, seconds(30)))
      << station_log();
  auto stranger = make_dds_agent_link(dds(), "stranger", null_logger());  // no credentials
  auto lost = make_dds_agent_link(with_bundle((run_dir_ / "lost_drone_1").string()), "drone_1",
                                  null_logger());
  std::uint64_t sequence = 0;
  const auto strangers_publish = [&] {
    stranger->publish(small_keyframe("stranger", sequence));
    lost->publish(small_keyframe("drone_1", sequence++));
  };
  // They publish from before the robot starts until it is done.
  strangers_publish();
  auto robot = start_agent(secured_agent("drone_0"));
  std::optional<mission::ExitStatus> status;
  ASSERT_TRUE(wait_until(
      [&] {
        strangers_publish();
        status = robot->poll();
        return status.has_value();
      },
      seconds(90)));
  ASSERT_TRUE(status->ok()) << mission::tail_of_file(robot->log_path(), 20);
  EXPECT_EQ(stored_counts()["drone_0"], 12);
  EXPECT_EQ(stranger->matched_stations(), 0u);
  EXPECT_EQ(lost->matched_stations(), 0u) << "the withdrawn robot was authenticated";

  const nlohmann::json report = stop_and_read_report(*station);
  EXPECT_EQ(report["refused_robots"]["over_quota"], 0) << report.dump(2);
  EXPECT_EQ(stored_counts(), (std::map<std::string, std::int64_t>{{"drone_0", 12}}));
  EXPECT_EQ(rows_for("rejected", "stranger"), 0);
  EXPECT_EQ(rows_for("rejected", "drone_1"), 0);
  EXPECT_EQ(report["dds_security"], true);
}

// The roster on its own, as a station whose DDS layer lets certified robots in (its bundle
// without the CRL): the withdrawn robot and one the roster does not list (an operator may
// narrow fleet.txt by hand) are refused, counted as such, and take no slot.
TEST_F(SecuredStationAdmission, RosterRefusesWithdrawnAndUnlistedRobots) {
  const auto bundle = run_dir_ / "station_without_crl";
  std::filesystem::copy(station_bundle(), bundle, std::filesystem::copy_options::recursive);
  std::filesystem::remove(bundle / "crl.pem");
  std::ofstream(bundle / "fleet.txt") << "# narrowed by hand\ndrone_0\n";
  auto station = start_station(secured_station(bundle.string(), 1));

  auto lost = make_dds_agent_link(with_bundle((run_dir_ / "lost_drone_1").string()), "drone_1",
                                  null_logger());
  ASSERT_TRUE(
      publish_until_logged(*lost, "drone_1", "robot 'drone_1' refused: withdrawn from the fleet"))
      << station_log();
  auto unlisted = make_dds_agent_link(with_bundle(mission::host_bundle(credentials_, "drone_2")),
                                      "drone_2", null_logger());
  ASSERT_TRUE(publish_until_logged(*unlisted, "drone_2",
                                   "robot 'drone_2' refused: no identity in the fleet"))
      << station_log();

  auto robot = start_agent(secured_agent("drone_0"));
  const auto status = robot->wait_for(seconds(90));
  ASSERT_TRUE(status && status->ok()) << mission::tail_of_file(robot->log_path(), 20);
  EXPECT_EQ(stored_counts()["drone_0"], 12);
  EXPECT_EQ(lost->matched_stations(), 0u) << "the station made a reader for a withdrawn robot";

  const nlohmann::json report = stop_and_read_report(*station);
  EXPECT_EQ(report["refused_robots"]["withdrawn"], 1) << report.dump(2);
  EXPECT_EQ(report["refused_robots"]["no_identity"], 1) << report.dump(2);
  EXPECT_EQ(report["refused_robots"]["over_quota"], 0) << report.dump(2);
  EXPECT_EQ(report["refused_robots"]["ids"], nlohmann::json::array({"drone_1", "drone_2"}));
  EXPECT_EQ(stored_counts(), (std::map<std::string, std::int64_t>{{"drone_0", 12}}));
}

}  // namespace
}  // namespace keyfleet::testing
