// The fleet's DDS-Security credentials as `keyfleet security init` and missions make them,
// checked with openssl itself: the chain verifies, the signed documents verify and say what
// each identity may do; each host's bundle holds its own key only; a withdrawn robot leaves the
// roster and its certificate is revoked.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>

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
    const auto [code, text] =
        shell("openssl smime -verify -text -in " + signed_file + " -CAfile " + files("station").ca);
    EXPECT_EQ(code, 0) << text;
    return text;
  }
  std::string dir() const { return dir_.path().string(); }
  SecurityFiles files(const std::string& host) const {
    return security_files(host_bundle(dir(), host), host);
  }
  test::TempDir dir_;
};

TEST_F(FleetCredentials, EveryIdentityHasACertificateTheCaSigned) {
  for (const char* id : {"drone_0", "drone_1", "station"}) {
    const SecurityFiles host = files(id);
    const auto [code, text] = shell("openssl verify -CAfile " + host.ca + " " + host.certificate);
    EXPECT_EQ(code, 0) << text;
    const auto [_, subject] = shell("openssl x509 -noout -subject -in " + host.certificate);
    EXPECT_NE(subject.find(std::string("CN = ") + id), std::string::npos) << subject;
    EXPECT_TRUE(std::filesystem::is_regular_file(host.private_key));
  }
}

TEST_F(FleetCredentials, PermissionsLetEachRobotPublishAsItselfOnly) {
  const std::string drone_0 = verify(files("drone_0").permissions);
  EXPECT_NE(drone_0.find("<subject_name>CN=drone_0</subject_name>"), std::string::npos);
  EXPECT_NE(drone_0.find("<publish><topics><topic>keyfleet/keyframes/drone_0</topic>"),
            std::string::npos)
      << drone_0;
  EXPECT_EQ(drone_0.find("drone_1"), std::string::npos) << drone_0;
  EXPECT_EQ(drone_0.find("<publish><topics><topic>keyfleet/keyframe_acks"), std::string::npos);
  const std::string station = verify(files("station").permissions);
  EXPECT_NE(station.find("<publish><topics><topic>keyfleet/keyframe_acks</topic>"),
            std::string::npos)
      << station;
  EXPECT_NE(station.find("<subscribe><topics><topic>keyfleet/keyframes/*</topic>"),
            std::string::npos);
}

TEST_F(FleetCredentials, IdentitiesAreVersion3EndEntitiesThatOnlySign) {
  for (const std::string id : {"drone_0", "station"}) {
    SCOPED_TRACE(id);
    const auto [code, text] = shell("openssl x509 -noout -text -in " + files(id).certificate);
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
  const std::string governance = verify(files("station").governance);
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
  const std::string path = files("drone_0").permissions;
  const auto [code, text] =
      shell("sed -i 's|keyfleet/keyframes/drone_0|keyfleet/keyframes/drone_1|' " + path +
            " && openssl smime -verify -text -in " + path + " -CAfile " + files("station").ca);
  EXPECT_NE(code, 0) << text;
}

// Every regular file under `folder`, relative to it.
std::set<std::string> files_under(const std::filesystem::path& folder) {
  std::set<std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder))
    if (entry.is_regular_file())
      files.insert(std::filesystem::relative(entry.path(), folder).string());
  return files;
}

std::filesystem::perms mode_of(const std::filesystem::path& path) {
  return std::filesystem::status(path).permissions() & std::filesystem::perms::all;
}

TEST_F(FleetCredentials, EachBundleHoldsItsHostsOwnKeyAndNoOtherSecret) {
  const auto bundle_of = [](const std::string& id) {
    return std::set<std::string>{"ca.cert.pem", "governance.p7s", "identities/" + id + ".cert.pem",
                                 "identities/" + id + ".key.pem",
                                 "identities/" + id + ".permissions.p7s"};
  };
  EXPECT_EQ(files_under(host_bundle(dir(), "drone_0")), bundle_of("drone_0"));
  EXPECT_EQ(files_under(host_bundle(dir(), "drone_1")), bundle_of("drone_1"));
  std::set<std::string> station = bundle_of("station");
  station.insert("fleet.txt");
  EXPECT_EQ(files_under(host_bundle(dir(), "station")), station);
  // The CA's key: in DIR/ca only, the owner's alone; the hosts' keys likewise.
  const auto ca = dir_.path() / "ca";
  ASSERT_TRUE(std::filesystem::is_regular_file(ca / "ca.key.pem"));
  EXPECT_EQ(mode_of(ca / "ca.key.pem"),
            std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  for (const auto& folder : {dir_.path(), ca, dir_.path() / "hosts",
                             std::filesystem::path(host_bundle(dir(), "drone_0"))})
    EXPECT_EQ(mode_of(folder), std::filesystem::perms::owner_all) << folder;
  EXPECT_EQ(mode_of(files("drone_0").private_key),
            std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  std::set<std::string> top;
  for (const auto& entry : std::filesystem::directory_iterator(dir_.path()))
    top.insert(entry.path().filename().string());
  EXPECT_EQ(top, (std::set<std::string>{"ca", "hosts"}));
}

TEST_F(FleetCredentials, TheStationsRosterListsTheRobotsIssued) {
  const FleetRoster roster = read_fleet_roster(host_bundle(dir(), "station"));
  EXPECT_EQ(roster.robots, (std::set<std::string>{"drone_0", "drone_1"}));
  EXPECT_TRUE(roster.withdrawn.empty());
  EXPECT_TRUE(roster.has("drone_0"));
  EXPECT_FALSE(roster.has("stranger"));
}

TEST_F(FleetCredentials, AWithdrawnRobotLeavesTheRosterAndItsCertificateIsRevoked) {
  withdraw_robot({dir(), "drone_1"}, null_logger());
  const std::string station = host_bundle(dir(), "station");
  const FleetRoster roster = read_fleet_roster(station);
  EXPECT_EQ(roster.robots, (std::set<std::string>{"drone_0"}));
  EXPECT_EQ(roster.withdrawn, (std::set<std::string>{"drone_1"}));
  EXPECT_FALSE(std::filesystem::exists(host_bundle(dir(), "drone_1"))) << "its key is gone";
  // The station's CRL, as PKI-DH checks it (X509_V_FLAG_CRL_CHECK): drone_1 revoked, drone_0
  // and the station itself still valid.
  const SecurityFiles s = files("station");
  const auto check = [&](const std::string& certificate) {
    return shell("openssl verify -crl_check -CAfile " + s.ca + " -CRLfile " + s.crl + " " +
                 certificate);
  };
  const auto [revoked, why] = check((dir_.path() / "ca" / "issued" / "drone_1.cert.pem").string());
  EXPECT_NE(revoked, 0) << why;
  EXPECT_NE(why.find("certificate revoked"), std::string::npos) << why;
  EXPECT_EQ(check(files("drone_0").certificate).first, 0);
  EXPECT_EQ(check(s.certificate).first, 0);
  // Again: nothing changes; an id without an identity is refused with the robots listed.
  withdraw_robot({dir(), "drone_1"}, null_logger());
  EXPECT_EQ(read_fleet_roster(station).withdrawn, (std::set<std::string>{"drone_1"}));
  try {
    withdraw_robot({dir(), "drone_7"}, null_logger());
    FAIL() << "drone_7 has no identity";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("'drone_7' has no identity"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("drone_0"), std::string::npos) << e.what();
  }
}

TEST_F(FleetCredentials, ReissuingWithoutARobotMakesANewCaItsOldCertificateFails) {
  const std::string old_certificate = (dir_.path() / "old_drone_1.cert.pem").string();
  std::filesystem::copy_file(files("drone_1").certificate, old_certificate);
  write_fleet_credentials({dir(), {"drone_0"}, 2}, null_logger());
  EXPECT_FALSE(std::filesystem::exists(host_bundle(dir(), "drone_1")));
  EXPECT_EQ(read_fleet_roster(host_bundle(dir(), "station")).robots,
            (std::set<std::string>{"drone_0"}));
  const auto [code, text] =
      shell("openssl verify -CAfile " + files("station").ca + " " + old_certificate);
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
