#pragma once
// The concrete verifiers, known only to the factory.
#include <memory>

#include "keyfleet/station/geometry/match_verifier.hpp"

namespace keyfleet::station::detail {

std::unique_ptr<MatchVerifier> make_ransac_verifier(bool homography, const RansacParams& params);

}  // namespace keyfleet::station::detail
