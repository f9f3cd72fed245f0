// MissionLog: appended records read back in order; a torn file is reported as corrupt.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/station/mission_log.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

constexpr std::int64_t kT0 = 1'700'000'000'000'000'000LL;

AgentStats some_stats() {
  AgentStats s;
  s.robot_id = "drone_1";
  s.report_time_ns = kT0;
  s.frames_seen = 300;
  s.stages = {{"encode", 3.5, 20}, {"publish", 1.25, 20}};
  return s;
}

std::vector<std::string> kinds_in(const std::string& path) {
  std::vector<std::string> kinds;
  const std::size_t count = read_mission_log_kinds(path, kinds);
  EXPECT_EQ(count, kinds.size());
  return kinds;
}

class MissionLogTest : public ::testing::Test {
 protected:
  keyfleet::test::TempDir dir_;
  std::string path_ = dir_.file("mission_log.pb");
};

TEST_F(MissionLogTest, RecordsReadBackInTheOrderWritten) {
  {
    MissionLog log(path_);
    EXPECT_EQ(log.path(), path_);
    log.event("station started", kT0);
    log.keyframe(keyfleet::test::make_valid_keyframe("drone_1", 0), 2048, kT0 + 1);
    log.rejected("drone_1", 1, "corrupt JPEG", kT0 + 2);
    log.agent_stats(some_stats());
    log.keyframe(keyfleet::test::make_valid_keyframe("drone_1", 2), 2048, kT0 + 3);
  }
  EXPECT_EQ(kinds_in(path_),
            (std::vector<std::string>{"event", "keyframe", "rejected", "agent_stats", "keyframe"}));
}

TEST_F(MissionLogTest, RecordsAreReadableWhileTheLogIsStillOpen) {
  MissionLog log(path_);
  log.keyframe(keyfleet::test::make_valid_keyframe("drone_1", 0), 2048, kT0);
  EXPECT_EQ(kinds_in(path_), (std::vector<std::string>{"keyframe"}));
}

TEST_F(MissionLogTest, ReopeningAppendsInsteadOfTruncating) {
  { MissionLog(path_).event("first run", kT0); }
  { MissionLog(path_).event("second run", kT0 + 1); }
  EXPECT_EQ(kinds_in(path_), (std::vector<std::string>{"event", "event"}));
}

TEST_F(MissionLogTest, ReadingAppendsToTheCallersList) {
  { MissionLog(path_).event("only", kT0); }
  std::vector<std::string> kinds{"already there"};
  EXPECT_EQ(read_mission_log_kinds(path_, kinds), 2u);
  EXPECT_EQ(kinds.back(), "event");
}

TEST_F(MissionLogTest, EmptyLogHasNoRecords) {
  { MissionLog log(path_); }
  EXPECT_TRUE(kinds_in(path_).empty());
}

TEST_F(MissionLogTest, FileTruncatedInsideARecordIsReportedAsCorrupt) {
  {
    MissionLog log(path_);
    log.event("station started", kT0);
    log.agent_stats(some_stats());
  }
  const auto full_size = std::filesystem::file_size(path_);
  std::vector<std::string> complete;
  ASSERT_EQ(read_mission_log_kinds(path_, complete), 2u);

  std::filesystem::resize_file(path_, full_size - 5);  // cuts the agent_stats record
  std::vector<std::string> kinds;
  EXPECT_THROW(read_mission_log_kinds(path_, kinds), std::runtime_error);
  EXPECT_EQ(kinds, (std::vector<std::string>{"event"}));
}

TEST_F(MissionLogTest, EveryCutInsideTheLastRecordIsReportedAsCorrupt) {
  std::uintmax_t first_size = 0;
  {
    MissionLog log(path_);
    log.event("station started", kT0);
    first_size = std::filesystem::file_size(path_);
    // A reason over 127 bytes makes the length prefix a two-byte varint, cut as well.
    log.rejected("drone_1", 1, std::string(300, 'r'), kT0 + 2);
  }
  const auto full_size = std::filesystem::file_size(path_);
  ASSERT_GT(full_size, first_size + 1);
  const std::string full = dir_.file("full.pb");
  std::filesystem::copy_file(path_, full);
  for (auto cut = first_size + 1; cut < full_size; ++cut) {
    std::filesystem::copy_file(full, path_, std::filesystem::copy_options::overwrite_existing);
    std::filesystem::resize_file(path_, cut);
    std::vector<std::string> kinds;
    EXPECT_THROW(read_mission_log_kinds(path_, kinds), std::runtime_error) << "cut at " << cut;
  }
}

TEST(MissionLogFull, AFailedWriteSaysWhyAndLeavesTheLogReadable) {
  MissionLog full("/dev/full");
  try {
    full.event("station started", 1);
    FAIL() << "a write to a full device succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
  }
}

TEST_F(MissionLogTest, MissingFileThrowsOnRead) {
  std::vector<std::string> kinds;
  EXPECT_THROW(read_mission_log_kinds(dir_.file("absent.pb"), kinds), std::runtime_error);
}

TEST_F(MissionLogTest, UnwritablePathThrowsStartupError) {
  EXPECT_THROW(MissionLog(dir_.file("no-such-dir/mission_log.pb")), StartupError);
}

}  // namespace
}  // namespace keyfleet::station
