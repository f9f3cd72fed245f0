#include "keyfleet/common/security_files.hpp"

#include <filesystem>
#include <fstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/printable_text.hpp"
#include "keyfleet/common/topic_names.hpp"

namespace keyfleet {
namespace {

namespace fs = std::filesystem;

std::string ways_out(const std::string& identity) {
  return "Make the fleet's credentials with `keyfleet security init --out DIR --robots <ids>` and "
         "set dds.security.directory to its bundle for this host, DIR/hosts/" +
         identity +
         ", or run without DDS-Security with `dds.security.enabled: false` (anyone who reaches "
         "the network can then read and forge keyframes)";
}

std::set<std::string> read_ids(const fs::path& path, bool required) {
  std::set<std::string> ids;
  std::ifstream in(path);
  if (!in) {
    if (!required && !fs::exists(path)) return ids;
    throw StartupError("dds.security: cannot read the fleet's roster " + path.string() +
                       " (written by `keyfleet security init` into the station's bundle)");
  }
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (!is_valid_robot_id(line))
      throw StartupError("dds.security: " + path.string() + ":" + std::to_string(number) + ": '" +
                         printable_text(line, 64) + "' is not a robot id ([A-Za-z0-9_-]{1,32})");
    ids.insert(line);
  }
  return ids;
}

}  // namespace

SecurityFiles security_files(const std::string& directory, const std::string& identity) {
  const fs::path dir(directory);
  const fs::path id = dir / "identities" / identity;
  return {(dir / "ca.cert.pem").string(),   (dir / "governance.p7s").string(),
          id.string() + ".cert.pem",        id.string() + ".key.pem",
          id.string() + ".permissions.p7s", (dir / "crl.pem").string(),
          (dir / "fleet.txt").string(),     (dir / "withdrawn.txt").string()};
}

void require_security_credentials(const DdsSecurity& security, const std::string& identity) {
  if (!security.enabled) return;
  const std::string on = "DDS-Security is on (dds.security.enabled, the default) but ";
  if (security.directory.empty())
    throw StartupError(on + "no credentials folder is set (dds.security.directory). " +
                       ways_out(identity) + ".");
  const std::string folder = fs::absolute(security.directory).lexically_normal().string();
  if (!fs::is_directory(security.directory))
    throw StartupError(on + "its credentials folder " + folder +
                       " (dds.security.directory) does not exist. " + ways_out(identity) + ".");
  const SecurityFiles files = security_files(security.directory, identity);
  const std::pair<const std::string*, const char*> needed[] = {
      {&files.ca, "the fleet's CA certificate"},
      {&files.governance, "the signed governance"},
      {&files.certificate, "this host's certificate"},
      {&files.private_key, "this host's private key"},
      {&files.permissions, "this host's signed permissions"}};
  for (const auto& [path, what] : needed)
    if (!fs::is_regular_file(*path))
      throw StartupError(on + "its credentials folder " + folder + " lacks " +
                         fs::relative(*path, security.directory).string() + " (" + what +
                         " for identity '" + identity + "'). " + ways_out(identity) + ".");
}

FleetRoster read_fleet_roster(const std::string& directory) {
  const SecurityFiles files = security_files(directory, kStationIdentity);
  FleetRoster roster;
  roster.robots = read_ids(files.roster, true);
  roster.withdrawn = read_ids(files.withdrawn, false);
  for (const auto& id : roster.withdrawn) roster.robots.erase(id);
  return roster;
}

}  // namespace keyfleet
