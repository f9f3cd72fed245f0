#pragma once
#include <opencv2/core/types.hpp>

#include <cstdint>
#include <vector>

namespace keyfleet::station {

// Sparse Vector Field Consensus (Ma et al., TIP 2014; sparse approximation: Pattern
// Recognition 2013). Defaults are the papers'. Distances are in normalised units: each
// point set is shifted to zero mean and scaled to unit RMS distance from it.
struct VfcParams {
  double gamma0 = 0.9;  // initial inlier fraction, in (0, 1)
  double beta = 0.1;    // Gaussian kernel exp(-beta |xi - xj|^2), 1 / normalised units^2
  double lambda = 3.0;  // smoothness weight of the field (Tikhonov term), > 0
  double theta = 0.75;  // posterior above which a match is an inlier, in (0, 1)
  double a = 10.0;      // area of the outliers' uniform displacement density, normalised units^2
  double min_relative_energy_change = 1e-5;  // EM stops below this |dE / E|
  int max_iterations = 500;                  // EM iterations (each = one E- and one M-step)
  int control_points = 16;                   // M: field basis size; cost is O(N M^2)
  std::uint32_t seed = 1;                    // control-point choice is deterministic
};

struct VfcResult {
  std::vector<int> inliers;  // indices into the inputs, ascending
  int iterations = 0;        // E-steps run
  double gamma = 0;          // final inlier fraction estimate
  double sigma2 = 0;         // final inlier displacement variance, normalised units^2
};

// Throws StartupError naming the bad field when a parameter is out of range.
void validate(const VfcParams& params);

// Inliers of the putative matches from[i] -> to[i]. Never throws: mismatched sizes, fewer
// than 8 matches, non-finite coordinates, a point set collapsed to one point or parameters
// out of range give an empty result.
VfcResult sparse_vfc(const std::vector<cv::Point2f>& from, const std::vector<cv::Point2f>& to,
                     const VfcParams& params = {});

}  // namespace keyfleet::station
