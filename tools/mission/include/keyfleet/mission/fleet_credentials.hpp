#pragma once
// A fleet's DDS-Security credentials, made with Debian's `openssl`: a CA, one X.509 v3
// certificate per robot (subject CN=<robot id>) and one for the station (CN=station), signed
// governance (no unauthenticated participants; data encrypted) and signed permissions (a robot
// may publish keyframes and stats on its own topics only and read acknowledgements; only the
// station may publish acknowledgements).
//
// Laid out for deployment, one bundle per host that holds its own key and nothing else secret:
//   DIR/hosts/<id>/   ca.cert.pem, governance.p7s, identities/<id>.{cert.pem,key.pem,
//                     permissions.p7s} (security_files.hpp): dds.security.directory of host <id>
//   DIR/hosts/station/ the same for "station", plus fleet.txt: the robot ids issued (the
//                     station admits no other), withdrawn.txt and crl.pem once one is withdrawn
//   DIR/ca/           the CA's key (0600; keep it off the hosts), its record of issued
//                     certificates and revocations, openssl's log
// Folders 0700, keys 0600. Running init again makes a new CA and replaces DIR/ca and DIR/hosts.
#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"

namespace keyfleet::mission {

struct FleetCredentialsRequest {
  std::string directory;               // created if missing; existing files are replaced
  std::vector<std::string> robot_ids;  // each [A-Za-z0-9_-]{1,32}
  int valid_days = 30;                 // certificates, permissions and CRLs, from now
  std::string openssl = "openssl";     // the program
};

// Throws StartupError naming the step that failed (with openssl's own words).
void write_fleet_credentials(const FleetCredentialsRequest& request, Logger logger);

// DIR/hosts/<host>: the bundle to give host `host` (a robot id, or "station").
std::string host_bundle(const std::string& directory, const std::string& host);

// Withdrawing a lost robot, so that the station refuses it from its next start (redeploy
// DIR/hosts/station there):
//  - its id leaves the station's roster (fleet.txt) for withdrawn.txt: the station's admission
//    refuses it and counts it as withdrawn (robot_admission.hpp);
//  - its certificate is revoked in a CRL (crl.pem in the station's bundle) that the station's
//    DDS participant passes to PKI-DH as dds.sec.auth.builtin.PKI-DH.identity_crl: Fast DDS
//    2.9.1 honours it (PKIDH::validate_local_identity adds it to the CA store and the handshake
//    verifies each peer's certificate with X509_V_FLAG_CRL_CHECK), so the robot is never
//    authenticated by the station. The CRL is valid as long as the certificates (valid_days);
//    robots do not get it, so the withdrawn key still authenticates to other robots, which
//    exchange nothing (a robot reads acknowledgements only). To lock it out of DDS entirely, on
//    every host, run init again with the robot left out (a new CA) and redeploy all bundles;
//  - its bundle in DIR/hosts is deleted.
// Throws StartupError when DIR is not init's or the robot has no identity there.
struct WithdrawRequest {
  std::string directory;
  std::string robot_id;
  std::string openssl = "openssl";
};
void withdraw_robot(const WithdrawRequest& request, Logger logger);

// The documents, exposed for tests: governance for domains 0..232, and the permissions of one
// identity (a robot id, or the station's) valid from `not_before` to `not_after`
// (YYYY-MM-DDThh:mm:ss, UTC).
std::string governance_xml();
std::string permissions_xml(const std::string& identity, bool is_station,
                            const std::string& not_before, const std::string& not_after);

}  // namespace keyfleet::mission
