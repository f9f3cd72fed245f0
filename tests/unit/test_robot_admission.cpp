// RobotAdmission: the fleet's roster, the allow-list, the quota, one log line per refused robot,
// bounded memory.
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>

#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "keyfleet/common/robot_admission.hpp"

namespace keyfleet {
namespace {

using Verdict = RobotAdmission::Verdict;

class RobotAdmissionTest : public ::testing::Test {
 protected:
  RobotAdmission make(std::vector<std::string> allowed, int max_robots) {
    StationLimits limits;
    limits.allowed_robots = std::move(allowed);
    limits.max_robots = max_robots;
    return RobotAdmission(limits, logger_);
  }
  std::size_t lines_mentioning(const std::string& what) const {
    std::istringstream lines(log_.str());
    std::size_t count = 0;
    for (std::string line; std::getline(lines, line);)
      count += line.find(what) != std::string::npos;
    return count;
  }

  std::ostringstream log_;
  Logger logger_ = std::make_shared<spdlog::logger>(
      "test", std::make_shared<spdlog::sinks::ostream_sink_mt>(log_));
};

TEST_F(RobotAdmissionTest, AnEmptyAllowListAdmitsAnyoneUpToTheQuota) {
  RobotAdmission admission = make({}, 2);
  EXPECT_EQ(admission.admit("alpha"), Verdict::kAdmitted);
  EXPECT_EQ(admission.admit("bravo"), Verdict::kAdmitted);
  EXPECT_EQ(admission.admit("alpha"), Verdict::kAdmitted) << "an admitted robot stays admitted";
  EXPECT_EQ(admission.admit("charlie"), Verdict::kOverQuota);
  EXPECT_EQ(admission.admitted_count(), 2u);
  EXPECT_EQ(admission.refusals().over_quota, 1u);
  EXPECT_EQ(lines_mentioning("robot 'charlie' refused: limits.max_robots"), 1u) << log_.str();
  EXPECT_EQ(lines_mentioning("(2)"), 1u) << "the quota is named: " << log_.str();
}

// Security on: an id without an identity never takes a slot, so a stranger who asks first
// cannot lock a robot of the fleet out; a withdrawn robot is refused and counted as such.
TEST_F(RobotAdmissionTest, WithARosterOnlyTheFleetsRobotsTakeSlots) {
  FleetRoster roster;
  roster.robots = {"drone_0", "drone_1"};
  roster.withdrawn = {"lost_drone"};
  StationLimits limits;
  limits.max_robots = 1;
  RobotAdmission admission(limits, logger_, roster);
  EXPECT_EQ(admission.admit("stranger"), Verdict::kNoIdentity);
  EXPECT_EQ(admission.admit("lost_drone"), Verdict::kWithdrawn);
  EXPECT_EQ(admission.admit("drone_1"), Verdict::kAdmitted) << "the only slot was still free";
  EXPECT_EQ(admission.admit("drone_0"), Verdict::kOverQuota);
  const RobotRefusals refusals = admission.refusals();
  EXPECT_EQ(refusals.no_identity, 1u);
  EXPECT_EQ(refusals.withdrawn, 1u);
  EXPECT_EQ(refusals.over_quota, 1u);
  EXPECT_EQ(refusals.ids, (std::vector<std::string>{"stranger", "lost_drone", "drone_0"}));
  EXPECT_EQ(lines_mentioning("robot 'stranger' refused: no identity in the fleet"), 1u)
      << log_.str();
  EXPECT_EQ(lines_mentioning("robot 'lost_drone' refused: withdrawn from the fleet"), 1u)
      << log_.str();
}

TEST_F(RobotAdmissionTest, TheRosterAndTheAllowListBothApply) {
  FleetRoster roster;
  roster.robots = {"drone_0", "drone_1"};
  StationLimits limits;
  limits.allowed_robots = {"drone_1", "drone_9"};
  RobotAdmission admission(limits, logger_, roster);
  EXPECT_EQ(admission.admit("drone_1"), Verdict::kAdmitted);
  EXPECT_EQ(admission.admit("drone_0"), Verdict::kNotAllowed);
  EXPECT_EQ(admission.admit("drone_9"), Verdict::kNoIdentity);
}

TEST_F(RobotAdmissionTest, OnlyTheAllowListIsAdmitted) {
  RobotAdmission admission = make({"drone_0", "drone_1"}, 64);
  EXPECT_EQ(admission.admit("drone_1"), Verdict::kAdmitted);
  EXPECT_EQ(admission.admit("stranger"), Verdict::kNotAllowed);
  EXPECT_EQ(admission.admit("drone_0"), Verdict::kAdmitted);
  const RobotRefusals refusals = admission.refusals();
  EXPECT_EQ(refusals.not_allowed, 1u);
  EXPECT_EQ(refusals.ids, (std::vector<std::string>{"stranger"}));
  EXPECT_EQ(lines_mentioning("robot 'stranger' refused: not on limits.allowed_robots"), 1u)
      << log_.str();
}

TEST_F(RobotAdmissionTest, MalformedIdsAreRefusedAndShownPrintable) {
  RobotAdmission admission = make({}, 64);
  EXPECT_EQ(admission.admit("../../etc"), Verdict::kMalformed);
  EXPECT_EQ(admission.admit(std::string("a\x01")), Verdict::kMalformed);
  EXPECT_EQ(admission.admitted_count(), 0u) << "a malformed id takes no place in the quota";
  EXPECT_EQ(admission.refusals().malformed, 2u);
  EXPECT_EQ(lines_mentioning("'a\\x01'"), 1u) << log_.str();
}

TEST_F(RobotAdmissionTest, EachRefusedRobotIsLoggedAndCountedOnceButEverySampleIsCounted) {
  RobotAdmission admission = make({"drone_0"}, 64);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(admission.admit("stranger"), Verdict::kNotAllowed);
    EXPECT_EQ(admission.admit_sample("stranger"), Verdict::kNotAllowed);
  }
  EXPECT_EQ(admission.admit_sample("drone_0"), Verdict::kAdmitted);
  const RobotRefusals refusals = admission.refusals();
  EXPECT_EQ(refusals.not_allowed, 1u);
  EXPECT_EQ(refusals.samples, 5u);
  EXPECT_EQ(lines_mentioning("stranger"), 1u) << log_.str();
}

TEST_F(RobotAdmissionTest, RememberedRefusalsAndListedIdsAreBounded) {
  RobotAdmission admission = make({"drone_0"}, 64);
  const std::size_t strangers = RobotAdmission::kRememberedRefusals + 10;
  for (std::size_t i = 0; i < strangers; ++i) admission.admit("s" + std::to_string(i));
  // Beyond the remembered ones each refusal counts again and is not logged.
  admission.admit("s" + std::to_string(strangers - 1));
  const RobotRefusals refusals = admission.refusals();
  EXPECT_EQ(refusals.not_allowed, strangers + 1);
  EXPECT_EQ(refusals.ids.size(), RobotRefusals::kListedIds);
  EXPECT_EQ(lines_mentioning("refused: not on"), RobotAdmission::kRememberedRefusals);
  EXPECT_EQ(lines_mentioning("further ones are counted, not logged"), 1u);
}

TEST_F(RobotAdmissionTest, ConcurrentCallersNeverExceedTheQuota) {
  RobotAdmission admission = make({}, 10);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&admission, t] {
      for (int i = 0; i < 50; ++i)
        admission.admit("r" + std::to_string(t) + "_" + std::to_string(i));
    });
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(admission.admitted_count(), 10u);
  EXPECT_EQ(admission.refusals().over_quota, 190u);
}

}  // namespace
}  // namespace keyfleet
