#include "keyfleet/mission/fleet_credentials.hpp"

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/governance.hpp"
#include "keyfleet/common/security_files.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/mission/child_process.hpp"

namespace keyfleet::mission {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxDomain = 232;

std::string utc_text(std::chrono::system_clock::time_point t) {
  const std::time_t seconds = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &tm);
  return text;
}

constexpr const char* kCaKey = "ca.key.pem";
constexpr const char* kCaCert = "ca.cert.pem";
constexpr const char* kCaConfig = "ca.cnf";

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  if (!out.flush()) throw StartupError("security: cannot write " + path.string());
}

void make_private_folder(const fs::path& path) {
  std::error_code ec;
  fs::create_directories(path, ec);
  if (!ec) fs::permissions(path, fs::perms::owner_all, fs::perm_options::replace, ec);
  if (ec) throw StartupError("security: cannot create " + path.string() + ": " + ec.message());
}

void make_private_file(const fs::path& path) {
  std::error_code ec;
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace,
                  ec);
  if (ec)
    throw StartupError("security: cannot make " + path.string() + " private: " + ec.message());
}

fs::path issued_certificate(const fs::path& ca_dir, const std::string& id) {
  return ca_dir / "issued" / (id + ".cert.pem");
}

class OpenSsl {
 public:
  OpenSsl(std::string program, fs::path log) : program_(std::move(program)), log_(std::move(log)) {}

  void run(const std::string& step, std::vector<std::string> args) {
    args.insert(args.begin(), program_);
    ChildProcess child("openssl", args, log_.string());
    const auto status = child.wait_for(std::chrono::seconds(60));
    if (!status || !status->ok())
      throw StartupError("security: openssl failed to " + step + " (" +
                         (status ? status->describe() : std::string("no answer in 60 s")) + "):\n" +
                         tail_of_file(log_.string(), 8));
  }

 private:
  std::string program_;
  fs::path log_;
};

std::string criteria(const std::vector<std::string>& topics) {
  std::string xml = "<topics>";
  for (const auto& t : topics) xml += "<topic>" + t + "</topic>";
  return xml + "</topics><partitions><partition>*</partition></partitions>";
}

}  // namespace

std::string governance_xml() {
  const GovernanceProtection& p = kFleetGovernance;
  const auto kind = [](bool on, const char* what) { return on ? std::string(what) : "NONE"; };
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>)" +
         std::to_string(kMaxDomain) + R"(</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>)" +
         kind(p.discovery, "ENCRYPT") + R"(</discovery_protection_kind>
      <liveliness_protection_kind>)" +
         kind(p.liveliness, "ENCRYPT") + R"(</liveliness_protection_kind>
      <rtps_protection_kind>)" +
         kind(p.rtps, "SIGN") + R"(</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>)" +
         std::string(p.discovery ? "true" : "false") + R"(</enable_discovery_protection>
          <enable_liveliness_protection>)" +
         std::string(p.liveliness ? "true" : "false") + R"(</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>)" +
         kind(p.metadata, "SIGN") + R"(</metadata_protection_kind>
          <data_protection_kind>)" +
         kind(p.payload, "ENCRYPT") + R"(</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
)";
}

std::string permissions_xml(const std::string& identity, bool is_station,
                            const std::string& not_before, const std::string& not_after) {
  const std::string keyframes = kKeyframeTopicPrefix, stats = kAgentStatsTopicPrefix;
  const std::string publish = is_station ? criteria({kKeyframeAckTopic})
                                         : criteria({keyframes + identity, stats + identity});
  const std::string subscribe =
      is_station ? criteria({keyframes + "*", stats + "*"}) : criteria({kKeyframeAckTopic});
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance">
  <permissions>
    <grant name=")" +
         identity + R"(">
      <subject_name>CN=)" +
         identity + R"(</subject_name>
      <validity><not_before>)" +
         not_before + "</not_before><not_after>" + not_after + R"(</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>)" +
         std::to_string(kMaxDomain) + R"(</max></id_range></domains>
        <publish>)" +
         publish + R"(</publish>
        <subscribe>)" +
         subscribe + R"(</subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
)";
}

std::string host_bundle(const std::string& directory, const std::string& host) {
  return (fs::path(directory) / "hosts" / host).string();
}

void write_fleet_credentials(const FleetCredentialsRequest& request, Logger logger) {
  if (request.directory.empty()) throw StartupError("security init: no output folder given");
  if (request.valid_days < 1)
    throw StartupError("security init: valid_days must be at least 1 (got " +
                       std::to_string(request.valid_days) + ")");
  for (const auto& id : request.robot_ids)
    if (!is_valid_robot_id(id) || id == kStationIdentity)
      throw StartupError("security init: robot id '" + id +
                         "' must match [A-Za-z0-9_-]{1,32} and not be '" + kStationIdentity + "'");
  const fs::path dir = fs::absolute(request.directory);
  const fs::path ca_dir = dir / "ca";
  // A new CA: what an earlier init left (another CA's bundles, a robot left out) goes.
  std::error_code ec;
  for (const fs::path& old : {ca_dir, dir / "hosts"}) {
    fs::remove_all(old, ec);
    if (ec)
      throw StartupError("security init: cannot replace " + old.string() + ": " + ec.message());
  }
  for (const fs::path& folder : {dir, ca_dir, ca_dir / "issued", dir / "hosts"})
    make_private_folder(folder);

  OpenSsl openssl(request.openssl, ca_dir / "openssl.log");
  const std::string days = std::to_string(request.valid_days);
  const std::string ca_key = (ca_dir / kCaKey).string();
  const std::string ca_cert = (ca_dir / kCaCert).string();
  openssl.run("make the CA",
              {"req",      "-x509",
               "-newkey",  "ec",
               "-pkeyopt", "ec_paramgen_curve:prime256v1",
               "-nodes",   "-sha256",
               "-days",    days,
               "-subj",    "/CN=keyfleet fleet CA",
               "-keyout",  ca_key,
               "-out",     ca_cert,
               "-addext",  "basicConstraints=critical,CA:TRUE",
               "-addext",  "keyUsage=critical,keyCertSign,cRLSign,digitalSignature"});
  make_private_file(ca_key);
  // openssl's CA record, for `security withdraw` (revocations, CRLs valid as long as the
  // certificates).
  write_file(ca_dir / "index.txt", "");
  write_file(ca_dir / "crlnumber", "01\n");
  write_file(ca_dir / kCaConfig,
             "[ca]\ndefault_ca = fleet\n[fleet]\ndatabase = " + (ca_dir / "index.txt").string() +
                 "\ncrlnumber = " + (ca_dir / "crlnumber").string() +
                 "\ndefault_md = sha256\ndefault_crl_days = " + days + "\n");

  const auto now = std::chrono::system_clock::now();
  const std::string not_before = utc_text(now - std::chrono::hours(1));
  const std::string not_after = utc_text(now + std::chrono::hours(24) * request.valid_days);
  const fs::path governance_xml_path = ca_dir / "governance.xml";
  const fs::path governance = ca_dir / "governance.p7s";
  write_file(governance_xml_path, governance_xml());
  openssl.run("sign the governance",
              {"smime", "-sign", "-text", "-in", governance_xml_path.string(), "-out",
               governance.string(), "-signer", ca_cert, "-inkey", ca_key});

  std::vector<std::string> identities = request.robot_ids;
  identities.push_back(kStationIdentity);
  // X.509 v3 identities: an end entity (not a CA) whose key only signs (the PKI-DH handshake's
  // signatures; the key agreement uses ephemeral keys).
  const fs::path extensions = ca_dir / "identity_extensions.cnf";
  write_file(extensions,
             "[identity]\n"
             "basicConstraints = critical, CA:FALSE\n"
             "keyUsage = critical, digitalSignature\n"
             "subjectKeyIdentifier = hash\n"
             "authorityKeyIdentifier = keyid\n");
  int serial = 1;
  for (const auto& id : identities) {
    const std::string bundle = host_bundle(dir.string(), id);
    make_private_folder(bundle);
    make_private_folder(fs::path(bundle) / "identities");
    const SecurityFiles files = security_files(bundle, id);
    const std::string request_path = (ca_dir / (id + ".csr.pem")).string();
    openssl.run(
        "make the key of " + id,
        {"req", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
         "-sha256", "-subj", "/CN=" + id, "-keyout", files.private_key, "-out", request_path});
    make_private_file(files.private_key);
    openssl.run("certify " + id,
                {"x509", "-req", "-sha256", "-days", days, "-in", request_path, "-CA", ca_cert,
                 "-CAkey", ca_key, "-set_serial", std::to_string(++serial), "-extfile",
                 extensions.string(), "-extensions", "identity", "-out", files.certificate});
    fs::remove(request_path, ec);
    fs::copy_file(files.certificate, issued_certificate(ca_dir, id),
                  fs::copy_options::overwrite_existing);
    const fs::path xml = ca_dir / (id + ".permissions.xml");
    write_file(xml, permissions_xml(id, id == kStationIdentity, not_before, not_after));
    openssl.run("sign the permissions of " + id,
                {"smime", "-sign", "-text", "-in", xml.string(), "-out", files.permissions,
                 "-signer", ca_cert, "-inkey", ca_key});
    fs::copy_file(ca_cert, files.ca, fs::copy_options::overwrite_existing);
    fs::copy_file(governance, files.governance, fs::copy_options::overwrite_existing);
  }
  std::string roster = "# robot ids with an identity from this CA; the station admits no other\n";
  for (const auto& id : request.robot_ids) roster += id + "\n";
  write_file(security_files(host_bundle(dir.string(), kStationIdentity), kStationIdentity).roster,
             roster);
  logger->info(
      "DDS-Security credentials for {} robot(s) and the station in {} (valid {} days): give "
      "each host its bundle {}/<id>; the CA's key stays in {}",
      request.robot_ids.size(), dir.string(), request.valid_days, (dir / "hosts").string(),
      ca_dir.string());
}

void withdraw_robot(const WithdrawRequest& request, Logger logger) {
  const fs::path dir = fs::absolute(request.directory);
  const fs::path ca_dir = dir / "ca";
  const std::string station = host_bundle(dir.string(), kStationIdentity);
  const SecurityFiles station_files = security_files(station, kStationIdentity);
  for (const fs::path& needed :
       {ca_dir / kCaKey, ca_dir / kCaConfig, fs::path(station_files.roster)})
    if (!fs::is_regular_file(needed))
      throw StartupError("security withdraw: " + dir.string() +
                         " is not a folder of `keyfleet security init` (no " + needed.string() +
                         ")");
  const std::string& id = request.robot_id;
  const FleetRoster roster = read_fleet_roster(station);
  const bool again = roster.withdrawn.count(id) > 0;
  if (!again && !roster.robots.count(id)) {
    std::string ids;
    for (const auto& r : roster.robots) ids += (ids.empty() ? "" : ", ") + r;
    throw StartupError("security withdraw: '" + id + "' has no identity in " + dir.string() +
                       " (its robots: " + (ids.empty() ? "none" : ids) + ")");
  }

  OpenSsl openssl(request.openssl, ca_dir / "openssl.log");
  const std::vector<std::string> ca = {"-config",  (ca_dir / kCaConfig).string(),
                                       "-keyfile", (ca_dir / kCaKey).string(),
                                       "-cert",    (ca_dir / kCaCert).string()};
  const auto with_ca = [&ca](std::vector<std::string> args) {
    args.insert(args.begin() + 1, ca.begin(), ca.end());
    return args;
  };
  if (!again)
    openssl.run("revoke the certificate of " + id,
                with_ca({"ca", "-revoke", issued_certificate(ca_dir, id).string()}));
  openssl.run("write the CRL", with_ca({"ca", "-gencrl", "-out", station_files.crl}));

  std::string fleet = "# robot ids with an identity from this CA; the station admits no other\n";
  for (const auto& r : roster.robots)
    if (r != id) fleet += r + "\n";
  write_file(station_files.roster, fleet);
  std::string withdrawn = "# robot ids withdrawn (`keyfleet security withdraw`)\n";
  for (const auto& r : roster.withdrawn) withdrawn += r + "\n";
  if (!again) withdrawn += id + "\n";
  write_file(station_files.withdrawn, withdrawn);
  std::error_code ec;
  fs::remove_all(host_bundle(dir.string(), id), ec);
  logger->info(
      "robot '{}' withdrawn{}: give the station its bundle {} again (roster, withdrawn.txt, "
      "crl.pem); it refuses the robot from its next start",
      id, again ? " (again)" : "", station);
}

}  // namespace keyfleet::mission
