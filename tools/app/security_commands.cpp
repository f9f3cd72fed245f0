// `keyfleet security init|withdraw`: DDS-Security credentials for a real fleet (a mission makes
// its own).
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"

namespace keyfleet::commands {

void add_security_commands(CLI::App& app) {
  auto* security = app.add_subcommand("security", "DDS-Security credentials for a fleet");
  security->require_subcommand(1);
  auto* init = security->add_subcommand(
      "init",
      "a new CA and one bundle per host in DIR/hosts/<id>: the CA certificate, signed "
      "governance, the host's own certificate, key and signed permissions (the station's also "
      "the fleet's roster, fleet.txt: it admits no other robot id). Give each host only its "
      "bundle and set its dds.security.directory to it; the CA's key stays in DIR/ca. Running "
      "it again replaces the CA and every bundle");
  auto request = std::make_shared<mission::FleetCredentialsRequest>();
  init->add_option("--out", request->directory, "credentials folder (keep it private)")->required();
  init->add_option("--robots", request->robot_ids, "robot ids, comma separated")
      ->required()
      ->delimiter(',');
  init->add_option("--days", request->valid_days, "validity of certificates and permissions")
      ->capture_default_str();
  init->callback([request] {
    run_reporting([&] {
      mission::write_fleet_credentials(*request, make_logger("security", "info"));
      std::cout << "bundles in " << request->directory << "/hosts/<robot id|station>: "
                << "ca.cert.pem, governance.p7s, identities/<id>.{cert.pem,key.pem,"
                << "permissions.p7s}; the station's also fleet.txt\n";
    });
  });

  auto* withdraw = security->add_subcommand(
      "withdraw",
      "withdraw a lost robot: it leaves the station's roster (DIR/hosts/station/fleet.txt, "
      "recorded in withdrawn.txt) and its certificate is revoked in DIR/hosts/station/crl.pem, "
      "which Fast DDS 2.9.1's PKI-DH checks in its handshake (identity_crl): redeploy the "
      "station's bundle and the station refuses the robot from its next start. Robots do not "
      "check the CRL; to lock the robot's key out of DDS on every host, run `security init` "
      "again without it (a new CA) and redeploy every bundle");
  auto withdrawal = std::make_shared<mission::WithdrawRequest>();
  withdraw->add_option("--out", withdrawal->directory, "credentials folder of `security init`")
      ->required();
  withdraw->add_option("--robot", withdrawal->robot_id, "the robot id to withdraw")->required();
  withdraw->callback([withdrawal] {
    run_reporting([&] {
      mission::withdraw_robot(*withdrawal, make_logger("security", "info"));
      std::cout << "'" << withdrawal->robot_id << "' withdrawn: redeploy "
                << mission::host_bundle(withdrawal->directory, "station")
                << " to the station and restart it\n";
    });
  });
}

}  // namespace keyfleet::commands
