// The YAML names of the geometric verifiers (verifier_kind_yaml.hpp).
#include "keyfleet/station/geometry/verifier_kind_yaml.hpp"

namespace keyfleet {

std::optional<VerifierKind> verifier_kind(const std::string& name) {
  return enum_from_name<VerifierKind>(name);
}
std::string verifier_kind_choices() { return enum_choices<VerifierKind>(); }

}  // namespace keyfleet
