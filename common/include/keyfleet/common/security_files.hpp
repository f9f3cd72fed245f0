#pragma once
// Where a fleet's DDS-Security credentials lie in the folder `keyfleet security init` writes;
// the DDS adapter reads them, the generator writes them.
#include <string>

namespace keyfleet {

struct SecurityFiles {
  std::string ca;           // ca.cert.pem: the CA of identities and of signed documents
  std::string governance;   // governance.p7s: the domain's rules, signed by the CA
  std::string certificate;  // identities/<id>.cert.pem: subject CN=<id>, signed by the CA
  std::string private_key;  // identities/<id>.key.pem
  std::string permissions;  // identities/<id>.permissions.p7s: what <id> may do, signed
};

SecurityFiles security_files(const std::string& directory, const std::string& identity);

}  // namespace keyfleet
