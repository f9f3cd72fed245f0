#pragma once
// Which geometric verifier place recognition runs (analysis.places.verifier in the station's
// config); make_match_verifier builds it. Its YAML names: verifier_kind_yaml.hpp.
#include <optional>
#include <string>

namespace keyfleet {

// How putative feature matches between two keyframes are verified geometrically: sparse Vector
// Field Consensus, or OpenCV's robust estimators of a homography or a fundamental matrix.
enum class VerifierKind { kVfc, kRansacHomography, kRansacFundamental };

// The names the YAML files give the verifiers, for the tools that take one on a command line.
std::optional<VerifierKind> verifier_kind(const std::string& name);
std::string verifier_kind_choices();

}  // namespace keyfleet
