// The station serves its allow-list and at most max_robots robots over real DDS: a stranger's
// topics are not read, it is logged once and counted in report.json, and nothing of it is stored.
#include <nlohmann/json.hpp>

#include <csignal>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::milliseconds;
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
  static Keyframe keyframe(const std::string& robot, std::uint64_t sequence) {
    Keyframe k;
    k.robot_id = robot;
    k.sequence_number = sequence;
    k.encoding = "jpeg";
    k.width = 64;
    k.height = 48;
    k.image = JpegCodec(80).encode(cv::Mat(48, 64, CV_8UC3, cv::Scalar(40, 120, 200)));
    return k;
  }
  // Publishes until the station logs `line` (the link publishes into the void meanwhile).
  bool publish_until_logged(AgentLink& link, const std::string& robot, const std::string& line) {
    std::uint64_t sequence = 0;
    return wait_until(
        [&] {
          link.publish(keyframe(robot, sequence++));
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
  stranger->publish(keyframe("stranger", 1000));

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
  std::optional<KeyframeAck> ack;
  ASSERT_TRUE(wait_until(
      [&] {
        if (!ack) first->publish(keyframe("first", 0));
        for (auto& a : first->take_acks("first", milliseconds(300)))
          if (!ack) ack = a;
        return ack.has_value();
      },
      seconds(20)));
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

}  // namespace
}  // namespace keyfleet::testing
