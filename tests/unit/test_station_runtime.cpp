// The whole station in process, as its main runs it, with the in-memory link in place of DDS:
// what it stores and acknowledges, the reports it writes, its dashboard, and what it refuses
// to start with.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include "fake_links.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/station/station_config.hpp"
#include "keyfleet/station/station_runtime.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

namespace fs = std::filesystem;

class StationRuntimeTest : public ::testing::Test {
 protected:
  StationRuntimeTest() {
    config_.dds.security.enabled = false;
    config_.analysis.text.enabled = false;
    config_.analysis.places.enabled = false;
    config_.log_level = "warn";
  }
  // A factory that hands the runtime the test's link and keeps a pointer to it.
  StationLinkFactory fake_link() {
    return [this](const DdsSettings&, Logger, std::shared_ptr<RobotAdmission>) {
      auto link = std::make_unique<test::FakeStationLink>();
      link_ = link.get();
      return link;
    };
  }
  static ReceivedKeyframe received(const std::string& robot, std::uint64_t sequence) {
    ReceivedKeyframe r;
    r.keyframe = test::make_valid_keyframe(robot, sequence);
    r.serialized_bytes = r.keyframe.image.size() + 100;
    r.sender = robot;
    return r;
  }

  test::TempDir dir_;
  StationConfig config_;
  StationFolders folders_{dir_.file("run"), ""};
  test::FakeStationLink* link_ = nullptr;
};

TEST_F(StationRuntimeTest, StoresAcknowledgesAndWritesItsReports) {
  StationRuntime station(config_, folders_, fake_link());
  ASSERT_NE(link_, nullptr);
  EXPECT_EQ(station.dashboard_url().rfind("http://127.0.0.1:", 0), 0u) << station.dashboard_url();
  EXPECT_TRUE(fs::exists(fs::path(folders_.run_dir) / "dashboard.url"));
  StationInbox inbox;
  inbox.keyframes = {received("drone_0", 0), received("drone_0", 1)};
  link_->queue(std::move(inbox));
  EXPECT_EQ(station.step(std::chrono::milliseconds(0)), 2u);
  ASSERT_EQ(link_->acks.size(), 2u);
  EXPECT_EQ(link_->acks[1].sequence_number, 1u);

  EXPECT_EQ(station.finish(), 0);
  EXPECT_FALSE(fs::exists(fs::path(folders_.run_dir) / "dashboard.url"));
  std::ifstream in(station.report_path());
  const auto report = nlohmann::json::parse(in);
  EXPECT_EQ(report["fleet"]["keyframes_stored"], 2) << report.dump(2);
  EXPECT_EQ(report["dds_security"], false);
  EXPECT_TRUE(fs::exists(fs::path(folders_.run_dir) / "report.txt"));
}

TEST_F(StationRuntimeTest, SecuredWithoutCredentialsItMakesNothing) {
  config_.dds.security.enabled = true;
  config_.dds.security.directory = dir_.file("no_such_bundle");
  EXPECT_THROW(StationRuntime(config_, folders_, fake_link()), StartupError);
  EXPECT_FALSE(fs::exists(folders_.run_dir)) << "a run folder was made";
  EXPECT_EQ(link_, nullptr) << "a link was made";
}

TEST_F(StationRuntimeTest, ASecondStationOnTheSameRunFolderIsRefused) {
  config_.dashboard.enabled = false;
  StationRuntime first(config_, folders_, fake_link());
  EXPECT_THROW(StationRuntime(config_, folders_, fake_link()), StartupError);
  EXPECT_EQ(first.finish(), 0) << "the first goes on";
}

}  // namespace
}  // namespace keyfleet::station
