#pragma once
// Where a host's DDS-Security credentials lie: one bundle per host, as `keyfleet security init`
// writes them (DIR/hosts/<id>/); the DDS adapter and the station read them, the generator writes
// them. A bundle holds its own host's key only, never another host's nor the CA's.
#include <set>
#include <string>

#include "keyfleet/common/config.hpp"

namespace keyfleet {

struct SecurityFiles {
  std::string ca;           // ca.cert.pem: the CA of identities and of signed documents
  std::string governance;   // governance.p7s: the domain's rules, signed by the CA
  std::string certificate;  // identities/<id>.cert.pem: subject CN=<id>, signed by the CA
  std::string private_key;  // identities/<id>.key.pem
  std::string permissions;  // identities/<id>.permissions.p7s: what <id> may do, signed
  // The station's bundle only: crl.pem (certificates withdrawn, signed by the CA; present once
  // a robot was withdrawn), fleet.txt (the robot ids with an identity, one a line) and
  // withdrawn.txt (ids withdrawn since, one a line; may be absent).
  std::string crl;
  std::string roster;
  std::string withdrawn;
};

SecurityFiles security_files(const std::string& directory, const std::string& identity);

// Refuses (StartupError) DDS-Security settings whose credentials cannot be used: the folder or
// one of the files `identity` needs is missing. The message names what is missing and the two
// ways out (`keyfleet security init`, or `dds.security.enabled: false`). Does nothing when
// security is off.
void require_security_credentials(const DdsSecurity& security, const std::string& identity);

// The robots a secured station serves: those `keyfleet security init` issued identities for,
// less those withdrawn since.
struct FleetRoster {
  std::set<std::string> robots;     // on fleet.txt
  std::set<std::string> withdrawn;  // on withdrawn.txt (never also on fleet.txt)
  bool has(const std::string& robot_id) const {
    return robots.count(robot_id) > 0 && withdrawn.count(robot_id) == 0;
  }
};

// Reads the roster of the station's bundle `directory`; throws StartupError when fleet.txt is
// missing or a line is not a robot id. Blank lines and lines starting with '#' are skipped.
FleetRoster read_fleet_roster(const std::string& directory);

}  // namespace keyfleet
