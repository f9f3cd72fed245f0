// The fleet's DDS-Security credentials as `keyfleet security init` and missions make them,
// checked with openssl itself: the chain verifies, the signed documents verify and say what
// each identity may do.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/security_files.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"
#include "test_support.hpp"

namespace keyfleet::mission {
namespace {

// Runs a shell command; returns (exit code, what it printed).
std::pair<int, std::string> shell(const std::string& command) {
  std::string output;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(::popen((command + " 2>&1").c_str(), "r"), ::pclose);
  if (!pipe) return {-1, ""};
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe.get())) output += buffer.data();
  const int status = ::pclose(pipe.release());
  return {WEXITSTATUS(status), output};
}

class FleetCredentials : public ::testing::Test {
 protected:
  void SetUp() override {
    write_fleet_credentials({dir_.path().string(), {"drone_0", "drone_1"}, 2}, null_logger());
  }
  std::string verify(const std::string& signed_file) {
    const auto [code, text] = shell("openssl smime -verify -text -in " + signed_file + " -CAfile " +
                                    security_files(dir(), "station").ca);
    EXPECT_EQ(code, 0) << text;
    return text;
  }
  std::string dir() const { return dir_.path().string(); }
  test::TempDir dir_;
};

TEST_F(FleetCredentials, EveryIdentityHasACertificateTheCaSigned) {
  for (const char* id : {"drone_0", "drone_1", "station"}) {
    const SecurityFiles files = security_files(dir(), id);
    const auto [code, text] = shell("openssl verify -CAfile " + files.ca + " " + files.certificate);
    EXPECT_EQ(code, 0) << text;
    const auto [_, subject] = shell("openssl x509 -noout -subject -in " + files.certificate);
    EXPECT_NE(subject.find(std::string("CN = ") + id), std::string::npos) << subject;
    EXPECT_TRUE(std::filesystem::is_regular_file(files.private_key));
  }
}

TEST_F(FleetCredentials, PermissionsLetEachRobotPublishAsItselfOnly) {
  const std::string drone_0 = verify(security_files(dir(), "drone_0").permissions);
  EXPECT_NE(drone_0.find("<subject_name>CN=drone_0</subject_name>"), std::string::npos);
  EXPECT_NE(drone_0.find("<publish><topics><topic>keyfleet/keyframes/drone_0</topic>"),
            std::string::npos)
      << drone_0;
  EXPECT_EQ(drone_0.find("drone_1"), std::string::npos) << drone_0;
  EXPECT_EQ(drone_0.find("<publish><topics><topic>keyfleet/keyframe_acks"), std::string::npos);
  const std::string station = verify(security_files(dir(), "station").permissions);
  EXPECT_NE(station.find("<publish><topics><topic>keyfleet/keyframe_acks</topic>"),
            std::string::npos)
      << station;
  EXPECT_NE(station.find("<subscribe><topics><topic>keyfleet/keyframes/*</topic>"),
            std::string::npos);
}

TEST_F(FleetCredentials, IdentitiesAreVersion3EndEntitiesThatOnlySign) {
  for (const std::string id : {"drone_0", "station"}) {
    SCOPED_TRACE(id);
    const auto [code, text] =
        shell("openssl x509 -noout -text -in " + security_files(dir(), id).certificate);
    ASSERT_EQ(code, 0) << text;
    EXPECT_NE(text.find("Version: 3"), std::string::npos) << text;
    EXPECT_NE(text.find("X509v3 Basic Constraints: critical"), std::string::npos) << text;
    EXPECT_NE(text.find("CA:FALSE"), std::string::npos) << text;
    EXPECT_NE(text.find("X509v3 Key Usage: critical"), std::string::npos) << text;
    EXPECT_NE(text.find("Digital Signature"), std::string::npos) << text;
    EXPECT_EQ(text.find("Certificate Sign"), std::string::npos)
        << "an identity must not sign certificates";
  }
}

TEST_F(FleetCredentials, GovernanceAdmitsNoStrangerAndEncrypts) {
  const std::string governance = verify(security_files(dir(), "station").governance);
  EXPECT_NE(governance.find("<allow_unauthenticated_participants>false"), std::string::npos);
  EXPECT_NE(governance.find("<enable_join_access_control>true"), std::string::npos);
  EXPECT_NE(governance.find("<enable_read_access_control>true"), std::string::npos);
  EXPECT_NE(governance.find("<enable_write_access_control>true"), std::string::npos);
  EXPECT_NE(governance.find("<data_protection_kind>ENCRYPT"), std::string::npos);
  // The protections the DDS adapter sizes its messages for (governance.hpp), as measured on
  // radio links: no per-submessage signing, no encrypted discovery (docs/radio_links.md).
  EXPECT_NE(governance.find("<metadata_protection_kind>NONE"), std::string::npos);
  EXPECT_NE(governance.find("<discovery_protection_kind>NONE"), std::string::npos);
  EXPECT_NE(governance.find("<rtps_protection_kind>NONE"), std::string::npos);
}

TEST_F(FleetCredentials, ADocumentChangedAfterSigningFailsToVerify) {
  const std::string path = security_files(dir(), "drone_0").permissions;
  const auto [code, text] =
      shell("sed -i 's|keyfleet/keyframes/drone_0|keyfleet/keyframes/drone_1|' " + path +
            " && openssl smime -verify -text -in " + path + " -CAfile " +
            security_files(dir(), "station").ca);
  EXPECT_NE(code, 0) << text;
}

TEST(FleetCredentialsRequest, BadRobotIdsAndTheStationsNameAreRefused) {
  test::TempDir dir;
  for (const char* id : {"../x", "station", ""})
    EXPECT_THROW(write_fleet_credentials({dir.path().string(), {id}}, null_logger()), StartupError)
        << id;
}

}  // namespace
}  // namespace keyfleet::mission
