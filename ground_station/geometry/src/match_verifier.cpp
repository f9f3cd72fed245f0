#include "keyfleet/station/geometry/match_verifier.hpp"

#include <algorithm>
#include <string>

#include "keyfleet/common/error.hpp"
#include "verifiers.hpp"

namespace keyfleet::station {
namespace {

class VfcVerifier final : public MatchVerifier {
 public:
  explicit VfcVerifier(const VfcParams& params) : params_(params) {}

  Verification verify(const std::vector<cv::Point2f>& from,
                      const std::vector<cv::Point2f>& to) const override {
    Verification out;
    out.candidates = std::min(from.size(), to.size());
    out.inliers = sparse_vfc(from, to, params_).inliers;
    return out;
  }

  std::string name() const override { return "vfc"; }

 private:
  VfcParams params_;
};

}  // namespace

double Verification::inlier_ratio() const {
  return candidates == 0 ? 0.0
                         : static_cast<double>(inliers.size()) / static_cast<double>(candidates);
}

void validate(const RansacParams& p) {
  if (!(p.reprojection_px > 0))
    throw StartupError("RANSAC parameters: reprojection_px must be positive, got " +
                       std::to_string(p.reprojection_px));
  if (!(p.confidence > 0 && p.confidence < 1))
    throw StartupError("RANSAC parameters: confidence must be in (0, 1), got " +
                       std::to_string(p.confidence));
  if (p.max_iterations < 1)
    throw StartupError("RANSAC parameters: max_iterations must be >= 1, got " +
                       std::to_string(p.max_iterations));
}

std::unique_ptr<MatchVerifier> make_match_verifier(VerifierKind kind, const VfcParams& vfc,
                                                   const RansacParams& ransac) {
  switch (kind) {
    case VerifierKind::kVfc: validate(vfc); return std::make_unique<VfcVerifier>(vfc);
    case VerifierKind::kRansacHomography:
    case VerifierKind::kRansacFundamental:
      validate(ransac);
      return detail::make_ransac_verifier(kind == VerifierKind::kRansacHomography, ransac);
  }
  throw StartupError("unknown verifier kind");
}

VerifierKind parse_verifier_kind(const std::string& text) {
  if (const auto kind = verifier_kind(text)) return *kind;
  throw StartupError("unknown match verifier '" + text + "' (expected one of " +
                     verifier_kind_choices() + ")");
}

}  // namespace keyfleet::station
