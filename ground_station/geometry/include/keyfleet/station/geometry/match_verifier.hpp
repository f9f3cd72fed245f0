#pragma once
#include <opencv2/core/types.hpp>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "keyfleet/station/geometry/verifier_kind.hpp"
#include "keyfleet/station/geometry/vfc.hpp"

namespace keyfleet::station {

struct Verification {
  std::vector<int> inliers;  // indices of the surviving matches, ascending
  std::size_t candidates = 0;
  double inlier_ratio() const;  // 0 when there were no candidates
};

// The seam between place recognition and geometric verification of its matches.
// verify() never throws: bad input gives no inliers.
class MatchVerifier {
 public:
  virtual ~MatchVerifier() = default;
  virtual Verification verify(const std::vector<cv::Point2f>& from,
                              const std::vector<cv::Point2f>& to) const = 0;
  virtual std::string name() const = 0;
};

// The kinds are configuration values (verifier_kind.hpp), named there once for YAML and here
// alike.
using ::keyfleet::VerifierKind;

// OpenCV's robust estimators: usac = true picks cv::USAC_DEFAULT (OpenCV's USAC framework
// with its default settings), false the classic cv::RANSAC. Both are seeded, so repeatable.
struct RansacParams {
  double reprojection_px = 3.0;  // inlier threshold in pixels (transfer / epipolar distance)
  double confidence = 0.99;      // in (0, 1)
  int max_iterations = 2000;
  bool usac = true;
};

void validate(const RansacParams& params);

// Throws StartupError when a parameter is out of range.
std::unique_ptr<MatchVerifier> make_match_verifier(VerifierKind kind, const VfcParams& vfc = {},
                                                   const RansacParams& ransac = {});

// A verifier's configuration name ("vfc", ...); anything else throws StartupError.
VerifierKind parse_verifier_kind(const std::string& text);

}  // namespace keyfleet::station
