// `keyfleet security init`: DDS-Security credentials for a real fleet (a mission makes its own).
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
      "a CA, one certificate and permissions per robot and for the station, signed governance; "
      "give each robot its identities/<id>.* files and ca.cert.pem + governance.p7s, set "
      "dds.security.enabled and dds.security.directory in its config");
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
      std::cout << "credentials in " << request->directory << ": ca.cert.pem, governance.p7s, "
                << "identities/<robot id|station>.{cert.pem,key.pem,permissions.p7s}\n";
    });
  });
}

}  // namespace keyfleet::commands
