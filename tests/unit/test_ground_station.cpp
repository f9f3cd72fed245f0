// GroundStation driven through an in-memory StationLink: acks, exactly-once storage,
// and resilience to bad samples and storage failures.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "fake_links.hpp"
#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/transport.hpp"
#include "keyfleet/station/bandwidth_report.hpp"
#include "keyfleet/station/ground_station.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/keyframe_validator.hpp"
#include "keyfleet/station/mission_log.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

using keyfleet::test::FakeStationLink;

ReceivedKeyframe received(const Keyframe& k) {
  return ReceivedKeyframe{k, k.image.size() + 200, {}};
}

Keyframe corrupt_keyframe(const std::string& robot, std::uint64_t sequence) {
  Keyframe k = keyfleet::test::make_valid_keyframe(robot, sequence);
  k.image = keyfleet::test::random_bytes(k.image.size(), 99);
  return k;
}

class GroundStationTest : public ::testing::Test {
 protected:
  std::size_t step_with(std::vector<ReceivedKeyframe> keyframes,
                        std::vector<AgentStats> stats = {}) {
    StationInbox inbox;
    inbox.keyframes = std::move(keyframes);
    inbox.stats = std::move(stats);
    link_.queue(std::move(inbox));
    return station_.step(std::chrono::milliseconds(0));
  }

  std::vector<std::string> log_kinds() {
    std::vector<std::string> kinds;
    read_mission_log_kinds(log_.path(), kinds);
    return kinds;
  }

  keyfleet::test::TempDir dir_;
  StationLimits limits_;
  KeyframeStore store_{dir_.file("station.sqlite")};
  MissionLog log_{dir_.file("mission_log.pb")};
  FakeStationLink link_;
  GroundStation station_{limits_, store_, log_, link_, null_logger()};
};

TEST_F(GroundStationTest, StepWithNothingArrivedDoesNothing) {
  EXPECT_EQ(station_.step(std::chrono::milliseconds(5)), 0u);
  EXPECT_TRUE(link_.acks.empty());
  EXPECT_EQ(link_.last_wait, std::chrono::milliseconds(5));
  EXPECT_GT(link_.last_max_keyframes, 0u);
}

// Over DDS the sender is the robot of the topic the keyframe came on, which DDS-Security ties
// to the writer's certificate: a keyframe claiming another robot is refused, not stored.
TEST_F(GroundStationTest, KeyframeClaimingAnotherRobotThanItsWriterIsRejected) {
  ReceivedKeyframe forged = received(keyfleet::test::make_valid_keyframe("drone_0", 3));
  forged.sender = "drone_1";
  ReceivedKeyframe honest = received(keyfleet::test::make_valid_keyframe("drone_1", 3));
  honest.sender = "drone_1";
  EXPECT_EQ(step_with({forged, honest}), 2u);
  ASSERT_EQ(link_.acks.size(), 2u);
  EXPECT_EQ(link_.acks[0].status, AckStatus::kRejected);
  EXPECT_EQ(link_.acks[0].reason, "robot id 'drone_0' is not its writer's, 'drone_1'");
  EXPECT_EQ(link_.acks[1].status, AckStatus::kStored);
  EXPECT_FALSE(store_.load("drone_0", 3).has_value());
  EXPECT_TRUE(store_.load("drone_1", 3).has_value());
}

TEST_F(GroundStationTest, GoodDuplicateAndCorruptKeyframesGetMatchingAcks) {
  const Keyframe good = keyfleet::test::make_valid_keyframe("drone_0", 0);
  const std::size_t handled =
      step_with({received(good), received(good), received(corrupt_keyframe("drone_0", 1))});
  EXPECT_EQ(handled, 3u);

  ASSERT_EQ(link_.acks.size(), 3u);
  EXPECT_EQ(link_.acks[0].robot_id, "drone_0");
  EXPECT_EQ(link_.acks[0].sequence_number, 0u);
  EXPECT_EQ(link_.acks[0].status, AckStatus::kStored);
  EXPECT_EQ(link_.acks[1].sequence_number, 0u);
  EXPECT_EQ(link_.acks[1].status, AckStatus::kDuplicate);
  EXPECT_EQ(link_.acks[2].sequence_number, 1u);
  EXPECT_EQ(link_.acks[2].status, AckStatus::kRejected);
  EXPECT_FALSE(link_.acks[2].reason.empty());

  EXPECT_EQ(store_.keyframe_count(), 1u);
  const auto totals = store_.totals();
  ASSERT_EQ(totals.size(), 1u);
  EXPECT_EQ(totals[0].keyframes, 1u);
  EXPECT_EQ(totals[0].rejected, 1u);
  EXPECT_EQ(totals[0].serialized_bytes, good.image.size() + 200);
}

TEST_F(GroundStationTest, RejectedRobotIdThatIsNotUtf8IsRecordedAsPrintableText) {
  // Bytes that are not UTF-8 once stopped the station's JSON report from being written.
  const std::string hostile = std::string("\xff\xfe\x01id\\") + std::string(100, 'x');
  step_with({received(keyfleet::test::make_valid_keyframe(hostile, 3))});
  ASSERT_EQ(link_.acks.size(), 1u);
  EXPECT_EQ(link_.acks[0].status, AckStatus::kRejected);

  const auto totals = store_.totals();
  ASSERT_EQ(totals.size(), 1u);
  EXPECT_EQ(totals[0].robot_id.substr(0, 22), "\\xff\\xfe\\x01id\\x5cxxxx");
  EXPECT_EQ(totals[0].rejected, 1u);
  const std::string json = to_json(build_bandwidth_report(totals));
  EXPECT_NE(json.find("xff"), std::string::npos);
  EXPECT_EQ(log_kinds().back(), "rejected");
}

TEST(PrintableText, KeepsPrintableAsciiAndEscapesEveryOtherByte) {
  EXPECT_EQ(printable_text("drone_0"), "drone_0");
  EXPECT_EQ(printable_text(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(printable_text("caf\xc3\xa9"), "caf\\xc3\\xa9");
  EXPECT_EQ(printable_text(std::string(100, 'z')).size(), 64u);
  EXPECT_EQ(printable_text("abcdef", 3), "abc");
}

TEST_F(GroundStationTest, KeepsWorkingAfterABadKeyframe) {
  step_with({received(corrupt_keyframe("drone_0", 0))});
  ASSERT_EQ(link_.acks.size(), 1u);
  ASSERT_EQ(link_.acks[0].status, AckStatus::kRejected);

  step_with({received(keyfleet::test::make_valid_keyframe("drone_0", 1))});
  ASSERT_EQ(link_.acks.size(), 2u);
  EXPECT_EQ(link_.acks[1].status, AckStatus::kStored);
  EXPECT_EQ(store_.keyframe_count(), 1u);
}

TEST_F(GroundStationTest, MalformedRobotIdIsRejectedAndNotCountedAsARobot) {
  Keyframe k = keyfleet::test::make_valid_keyframe("bad id!", 0);
  step_with({received(k)});
  ASSERT_EQ(link_.acks.size(), 1u);
  EXPECT_EQ(link_.acks[0].status, AckStatus::kRejected);
  EXPECT_NE(link_.acks[0].reason.find("robot id"), std::string::npos) << link_.acks[0].reason;
  EXPECT_TRUE(station_.robots().empty());
  EXPECT_EQ(store_.keyframe_count(), 0u);
}

TEST_F(GroundStationTest, RepeatedRejectionIsLoggedOnceButAcknowledgedEachTime) {
  const Keyframe bad = corrupt_keyframe("drone_0", 4);
  step_with({received(bad), received(bad)});
  ASSERT_EQ(link_.acks.size(), 2u);
  EXPECT_EQ(link_.acks[0].status, AckStatus::kRejected);
  EXPECT_EQ(link_.acks[1].status, AckStatus::kRejected);
  EXPECT_EQ(link_.acks[0].reason, link_.acks[1].reason);
  EXPECT_EQ(log_kinds(), (std::vector<std::string>{"rejected"}));
}

TEST_F(GroundStationTest, MissionLogRecordsJoinStoreAndRejectionButNotDuplicates) {
  const Keyframe good = keyfleet::test::make_valid_keyframe("drone_0", 0);
  step_with({received(good), received(good), received(corrupt_keyframe("drone_0", 1))});
  EXPECT_EQ(log_kinds(), (std::vector<std::string>{"event", "keyframe", "rejected"}));
}

TEST_F(GroundStationTest, TracksEachRobotOnce) {
  step_with({received(keyfleet::test::make_valid_keyframe("alpha", 0)),
             received(keyfleet::test::make_valid_keyframe("alpha", 1)),
             received(keyfleet::test::make_valid_keyframe("bravo", 0))});
  EXPECT_EQ(station_.robots(), (std::set<std::string>{"alpha", "bravo"}));
  EXPECT_EQ(store_.keyframe_count(), 3u);
}

TEST_F(GroundStationTest, AgentStatsAreStoredAndLogged) {
  AgentStats stats;
  stats.robot_id = "drone_3";
  stats.report_time_ns = 1000;
  stats.frames_seen = 90;
  EXPECT_EQ(step_with({}, {stats}), 0u);
  const auto totals = store_.totals();
  ASSERT_EQ(totals.size(), 1u);
  ASSERT_TRUE(totals[0].latest_stats.has_value());
  EXPECT_EQ(totals[0].latest_stats->frames_seen, 90u);
  EXPECT_EQ(station_.robots().count("drone_3"), 1u);
  EXPECT_EQ(log_kinds(), (std::vector<std::string>{"event", "agent_stats"}));
}

TEST_F(GroundStationTest, AgentStatsWithMalformedRobotIdAreIgnored) {
  AgentStats stats;
  stats.robot_id = "not valid!";
  step_with({}, {stats});
  EXPECT_TRUE(store_.totals().empty());
  EXPECT_TRUE(station_.robots().empty());
  EXPECT_TRUE(log_kinds().empty());
}

TEST_F(GroundStationTest, FailedAcknowledgementDoesNotStopTheStation) {
  link_.acknowledge_ok = false;
  step_with({received(keyfleet::test::make_valid_keyframe("drone_0", 0))});
  link_.acknowledge_ok = true;
  step_with({received(keyfleet::test::make_valid_keyframe("drone_0", 0)),
             received(keyfleet::test::make_valid_keyframe("drone_0", 1))});
  ASSERT_EQ(link_.acks.size(), 3u);
  EXPECT_EQ(link_.acks[1].status, AckStatus::kDuplicate);  // the resend after a lost ack
  EXPECT_EQ(link_.acks[2].status, AckStatus::kStored);
  EXPECT_EQ(store_.keyframe_count(), 2u);
}

TEST_F(GroundStationTest, StorageFailureIsNotAcknowledgedSoTheAgentResends) {
  {
    SqliteDb saboteur(store_.path());
    saboteur.exec("DROP TABLE keyframes; DROP TABLE agent_stats");
  }
  std::size_t handled = 0;
  EXPECT_NO_THROW(handled =
                      step_with({received(keyfleet::test::make_valid_keyframe("drone_0", 0))}));
  EXPECT_EQ(handled, 1u);
  EXPECT_TRUE(link_.acks.empty());
  EXPECT_EQ(station_.storage_failures(), 1u);
  AgentStats stats;
  stats.robot_id = "drone_0";
  EXPECT_NO_THROW(step_with({}, {stats})) << "unstorable statistics stopped the station";
  EXPECT_EQ(station_.storage_failures(), 2u);
}

// The mission log on a device that is always full: every write fails. What the database holds is
// still acknowledged as stored; the log's failures are counted, not thrown.
TEST(GroundStationMissionLog, AFullMissionLogDoesNotHoldBackAcknowledgements) {
  keyfleet::test::TempDir dir;
  KeyframeStore store(dir.file("station.sqlite"));
  MissionLog full_log("/dev/full");
  EXPECT_THROW(full_log.event("probe", 1), std::runtime_error);
  FakeStationLink link;
  GroundStation station(StationLimits{}, store, full_log, link, null_logger());
  StationInbox inbox;
  inbox.keyframes = {received(keyfleet::test::make_valid_keyframe("drone_0", 0))};
  link.queue(std::move(inbox));
  EXPECT_EQ(station.step(std::chrono::milliseconds(0)), 1u);
  ASSERT_EQ(link.acks.size(), 1u);
  EXPECT_EQ(link.acks[0].status, AckStatus::kStored);
  EXPECT_EQ(store.keyframe_count(), 1u);
  EXPECT_EQ(station.storage_failures(), 0u);
}

TEST_F(GroundStationTest, HandleReturnsTheAckWithoutSendingIt) {
  const KeyframeAck ack =
      station_.handle(received(keyfleet::test::make_valid_keyframe("drone_0", 0)), 12345);
  EXPECT_EQ(ack.status, AckStatus::kStored);
  EXPECT_TRUE(link_.acks.empty());
  const auto totals = store_.totals();
  ASSERT_EQ(totals.size(), 1u);
  EXPECT_EQ(totals[0].first_received_ns, 12345);
}

void expect_not_served(const std::string& reason) {
  EXPECT_NE(reason.find("is not served: not on limits.allowed_robots"), std::string::npos)
      << reason;
}

StationLimits only_alpha() {
  StationLimits limits;
  limits.allowed_robots = {"alpha"};
  limits.max_robots = 2;
  return limits;
}

// A station serving only "alpha".
class GroundStationAdmissionTest : public ::testing::Test {
 protected:
  std::size_t step_with(std::vector<ReceivedKeyframe> keyframes, std::vector<AgentStats> stats) {
    StationInbox inbox;
    inbox.keyframes = std::move(keyframes);
    inbox.stats = std::move(stats);
    link_.queue(std::move(inbox));
    return station_.step(std::chrono::milliseconds(0));
  }

  keyfleet::test::TempDir dir_;
  KeyframeStore store_{dir_.file("station.sqlite")};
  MissionLog log_{dir_.file("mission_log.pb")};
  FakeStationLink link_;
  GroundStation station_{only_alpha(), store_, log_, link_, null_logger()};
};

TEST_F(GroundStationAdmissionTest, RobotNotAllowedIsRejectedWithoutATraceInTheDatabase) {
  ReceivedKeyframe stranger = received(keyfleet::test::make_valid_keyframe("stranger", 0));
  stranger.sender = "stranger";
  ReceivedKeyframe claiming = received(keyfleet::test::make_valid_keyframe("invented", 1));
  AgentStats stats;
  stats.robot_id = "stranger";
  EXPECT_EQ(step_with({stranger, stranger, claiming,
                       received(keyfleet::test::make_valid_keyframe("alpha", 0))},
                      {stats}),
            4u);
  ASSERT_EQ(link_.acks.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(link_.acks[i].status, AckStatus::kRejected);
    expect_not_served(link_.acks[i].reason);
  }
  EXPECT_EQ(link_.acks[3].status, AckStatus::kStored);

  EXPECT_EQ(station_.robots(), (std::set<std::string>{"alpha"}));
  const auto totals = store_.totals();
  ASSERT_EQ(totals.size(), 1u) << "no rejection, stats or keyframe row for a refused robot";
  EXPECT_EQ(totals[0].robot_id, "alpha");
  std::vector<std::string> kinds;
  read_mission_log_kinds(log_.path(), kinds);
  EXPECT_EQ(kinds, (std::vector<std::string>{"event", "keyframe"}));

  const RobotRefusals refusals = station_.admission().refusals();
  EXPECT_EQ(refusals.not_allowed, 2u);  // stranger, invented
  EXPECT_EQ(refusals.samples, 4u);      // three keyframes, one stats sample
  BandwidthReport report = build_bandwidth_report(totals);
  report.refused = refusals;
  const std::string json = to_json(report);
  EXPECT_NE(json.find("\"refused_robots\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"not_allowed\": 2"), std::string::npos) << json;
  EXPECT_NE(format_table(report).find("robots refused: 2 not allowed"), std::string::npos);
}

}  // namespace
}  // namespace keyfleet::station
