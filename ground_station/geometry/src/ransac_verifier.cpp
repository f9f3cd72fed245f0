#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>

#include "verifiers.hpp"

namespace keyfleet::station::detail {
namespace {

// The 8-point minimum of the fundamental matrix; also what VFC asks for.
constexpr std::size_t kMinMatches = 8;

bool all_finite(const std::vector<cv::Point2f>& points) {
  for (const auto& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
  }
  return true;
}

class RansacVerifier final : public MatchVerifier {
 public:
  RansacVerifier(bool homography, const RansacParams& params)
      : homography_(homography), params_(params) {}

  Verification verify(const std::vector<cv::Point2f>& from,
                      const std::vector<cv::Point2f>& to) const override {
    Verification out;
    out.candidates = std::min(from.size(), to.size());
    if (from.size() != to.size() || from.size() < kMinMatches || !all_finite(from) ||
        !all_finite(to))
      return out;
    const int method = params_.usac ? cv::USAC_DEFAULT : cv::RANSAC;
    std::vector<unsigned char> mask;
    try {
      const cv::Mat model =
          homography_ ? cv::findHomography(from, to, method, params_.reprojection_px, mask,
                                           params_.max_iterations, params_.confidence)
                      : cv::findFundamentalMat(from, to, method, params_.reprojection_px,
                                               params_.confidence, params_.max_iterations, mask);
      if (model.empty() || mask.size() != from.size()) return out;
    } catch (const cv::Exception&) {
      return out;  // degenerate configurations (e.g. collinear points) are a non-result
    }
    for (std::size_t i = 0; i < mask.size(); ++i) {
      if (mask[i] != 0) out.inliers.push_back(static_cast<int>(i));
    }
    return out;
  }

  std::string name() const override {
    return homography_ ? "ransac_homography" : "ransac_fundamental";
  }

 private:
  bool homography_;
  RansacParams params_;
};

}  // namespace

std::unique_ptr<MatchVerifier> make_ransac_verifier(bool homography, const RansacParams& params) {
  return std::make_unique<RansacVerifier>(homography, params);
}

}  // namespace keyfleet::station::detail
