#pragma once
// The YAML names of the geometric verifiers, for the descriptions that read a VerifierKind
// (place recognition's analysis.places.verifier).
#include <utility>

#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/station/geometry/verifier_kind.hpp"

namespace keyfleet {

template <>
struct EnumNames<VerifierKind> {
  static constexpr std::pair<VerifierKind, const char*> kAll[] = {
      {VerifierKind::kVfc, "vfc"},
      {VerifierKind::kRansacHomography, "ransac_homography"},
      {VerifierKind::kRansacFundamental, "ransac_fundamental"}};
};

}  // namespace keyfleet
