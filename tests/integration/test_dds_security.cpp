// DDS-Security over real participants in several processes: a secured station serves a
// secured robot; a participant without credentials neither delivers nor reads; a robot cannot
// write on another robot's topic, nor pass its keyframes off as another robot's.
#include <csignal>
#include <map>

#include "keyfleet/common/error.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

class DdsSecurity : public FleetFixture {
 protected:
  void SetUp() override {
    FleetFixture::SetUp();
    credentials_ = (run_dir_ / "security").string();
    mission::write_fleet_credentials({credentials_, {"drone_0", "drone_1"}}, null_logger());
  }
  // A robot's settings with its host's bundle, as `keyfleet security init` wrote it.
  DdsSettings secured(const std::string& robot_id) const {
    DdsSettings settings = dds();
    settings.security = {true, mission::host_bundle(credentials_, robot_id)};
    return settings;
  }
  StationConfig secured_station() const {
    StationConfig config = station_config();
    config.dds.security = {true, mission::host_bundle(credentials_, kStationIdentity)};
    return config;
  }
  // A credentials folder where `real`'s certificate, key and permissions lie under the name
  // `as`: a participant made "as" that identity authenticates as `real`.
  std::string disguised(const std::string& real, const std::string& as) const {
    const auto dir = run_dir_ / ("disguised-" + real + "-as-" + as);
    std::filesystem::create_directories(dir / "identities");
    const std::filesystem::path bundle = mission::host_bundle(credentials_, real);
    for (const char* file : {"ca.cert.pem", "governance.p7s"})
      std::filesystem::copy_file(bundle / file, dir / file);
    for (const char* suffix : {".cert.pem", ".key.pem", ".permissions.p7s"})
      std::filesystem::copy_file(bundle / "identities" / (real + suffix),
                                 dir / "identities" / (as + suffix));
    return dir.string();
  }
  std::string credentials_;
};

TEST_F(DdsSecurity, SecuredRobotIsServedAndStrangersGetNothing) {
  StationConfig config = secured_station();
  auto station = start_station(config);

  auto robot = make_dds_agent_link(secured("drone_0"), "drone_0", null_logger());
  auto stranger = make_dds_agent_link(dds(), "drone_1", null_logger());  // no credentials
  auto eavesdropper = make_dds_station_link(dds(), null_logger());       // no credentials
  ASSERT_TRUE(wait_until([&] { return robot->matched_stations() > 0; }, seconds(30)));

  const auto ack = first_answer(*robot, small_keyframe("drone_0", 0), seconds(20));
  ASSERT_TRUE(ack.has_value());
  EXPECT_EQ(ack->status, AckStatus::kStored);
  // By now the stranger has been announced to the station for as long as the robot took to be
  // authenticated and served: it was never matched, and its keyframe was never stored.
  stranger->publish(small_keyframe("drone_1", 0));
  EXPECT_EQ(stranger->matched_stations(), 0u);
  const auto again = first_answer(*robot, small_keyframe("drone_0", 1), seconds(20));
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(stored_counts()["drone_0"], 2);
  EXPECT_EQ(stored_counts().count("drone_1"), 0u);
  EXPECT_EQ(eavesdropper->matched_agents(), 0u);
  EXPECT_TRUE(eavesdropper->take(milliseconds(0), 64).keyframes.empty());

  station->signal(SIGTERM);
  const auto status = station->wait_for(seconds(30));
  ASSERT_TRUE(status && status->ok());
}

// Credentials of the right shape, from another CA: authentication fails, nothing is matched,
// while a robot of the fleet is served.
TEST_F(DdsSecurity, ParticipantCertifiedByAnotherCaIsNeverMatched) {
  const auto other = (run_dir_ / "other-ca").string();
  mission::write_fleet_credentials({other, {"drone_1"}}, null_logger());
  StationConfig config = secured_station();
  auto station = start_station(config);
  DdsSettings impostor_settings = dds();
  impostor_settings.security = {true, mission::host_bundle(other, "drone_1")};
  auto impostor = make_dds_agent_link(impostor_settings, "drone_1", null_logger());
  auto robot = make_dds_agent_link(secured("drone_0"), "drone_0", null_logger());
  const auto ack = first_answer(*robot, small_keyframe("drone_0", 0), seconds(30));
  ASSERT_TRUE(ack.has_value());
  impostor->publish(small_keyframe("drone_1", 0));
  EXPECT_EQ(impostor->matched_stations(), 0u);
  ASSERT_TRUE(first_answer(*robot, small_keyframe("drone_0", 1), seconds(20)).has_value());
  EXPECT_EQ(stored_counts().count("drone_1"), 0u);
  EXPECT_TRUE(impostor->take_acks("drone_0", milliseconds(0)).empty());  // reads no acks either

  station->signal(SIGTERM);
  const auto status = station->wait_for(seconds(30));
  ASSERT_TRUE(status && status->ok());
}

// Only the station may acknowledge: a robot's credentials cannot make an acknowledgement writer,
// so no forged ack can make a robot drop its copy.
TEST_F(DdsSecurity, RobotCannotPublishAcknowledgements) {
  DdsSettings settings = dds();
  settings.security = {true, disguised("drone_1", kStationIdentity)};
  try {
    auto forger = make_dds_station_link(settings, null_logger());
    FAIL() << "an acknowledgement writer was created with drone_1's credentials";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find(kKeyframeAckTopic), std::string::npos) << e.what();
  }
}

TEST_F(DdsSecurity, RobotCannotWriteOnAnotherRobotsTopic) {
  // drone_1's credentials presented as drone_0: its permissions allow drone_1's topics only.
  DdsSettings settings = dds();
  settings.security = {true, disguised("drone_1", "drone_0")};
  try {
    auto link = make_dds_agent_link(settings, "drone_0", null_logger());
    FAIL() << "a writer on drone_0's topic was created with drone_1's credentials";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("keyfleet/keyframes/drone_0"), std::string::npos)
        << e.what();
  }
}

TEST_F(DdsSecurity, KeyframeClaimingAnotherRobotIsRefused) {
  StationConfig config = secured_station();
  auto station = start_station(config);
  auto robot = make_dds_agent_link(secured("drone_1"), "drone_1", null_logger());
  ASSERT_TRUE(wait_until([&] { return robot->matched_stations() > 0; }, seconds(30)));

  const auto ack = first_answer(*robot, small_keyframe("drone_0", 7), seconds(20));
  ASSERT_TRUE(ack.has_value());
  EXPECT_EQ(ack->status, AckStatus::kRejected);
  EXPECT_NE(ack->reason.find("is not its writer's, 'drone_1'"), std::string::npos) << ack->reason;
  EXPECT_EQ(stored_counts().count("drone_0"), 0u);

  station->signal(SIGTERM);
  const auto status = station->wait_for(seconds(30));
  ASSERT_TRUE(status && status->ok());
}

}  // namespace
}  // namespace keyfleet::testing
