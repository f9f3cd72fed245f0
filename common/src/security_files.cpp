#include "keyfleet/common/security_files.hpp"

#include <filesystem>

namespace keyfleet {

SecurityFiles security_files(const std::string& directory, const std::string& identity) {
  const std::filesystem::path dir(directory);
  const std::filesystem::path id = dir / "identities" / identity;
  return {(dir / "ca.cert.pem").string(), (dir / "governance.p7s").string(),
          id.string() + ".cert.pem", id.string() + ".key.pem", id.string() + ".permissions.p7s"};
}

}  // namespace keyfleet
