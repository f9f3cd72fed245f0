#pragma once
// A fleet's DDS-Security credentials, made with Debian's `openssl`: a throwaway CA, one
// certificate per robot (subject CN=<robot id>) and one for the station (CN=station), signed
// governance (no unauthenticated participants; discovery, liveliness and data encrypted) and
// signed permissions (a robot may publish keyframes and stats on its own topics only and read
// acknowledgements; only the station may publish acknowledgements). Laid out as
// security_files.hpp says; the CA's private key stays in the folder (ca.key.pem) for adding
// robots later: keep the folder private.
#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"

namespace keyfleet::mission {

struct FleetCredentialsRequest {
  std::string directory;               // created if missing; existing files are replaced
  std::vector<std::string> robot_ids;  // each [A-Za-z0-9_-]{1,32}
  int valid_days = 30;                 // certificates and permissions, from now
  std::string openssl = "openssl";     // the program
};

// Throws StartupError naming the step that failed (with openssl's own words).
void write_fleet_credentials(const FleetCredentialsRequest& request, Logger logger);

// The documents, exposed for tests: governance for domains 0..232, and the permissions of one
// identity (a robot id, or the station's) valid from `not_before` to `not_after`
// (YYYY-MM-DDThh:mm:ss, UTC).
std::string governance_xml();
std::string permissions_xml(const std::string& identity, bool is_station,
                            const std::string& not_before, const std::string& not_after);

}  // namespace keyfleet::mission
