#include "keyfleet/station/geometry/vfc.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "keyfleet/common/error.hpp"

namespace keyfleet::station {
namespace {

using Points = Eigen::Matrix<double, Eigen::Dynamic, 2>;

constexpr std::size_t kMinMatches = 8;
constexpr double kPi = 3.14159265358979323846;
// The reference implementation stops once the noise variance is this small (exact data),
// and floors the posterior in the M-step so no match loses all weight.
constexpr double kMinSigma2 = 1e-8;
constexpr double kMinPosterior = 1e-5;
constexpr double kRidge = 1e-10;

bool in_open_unit(double v) { return v > 0.0 && v < 1.0; }

bool parameters_ok(const VfcParams& p) {
  return in_open_unit(p.gamma0) && in_open_unit(p.theta) && p.beta > 0 && p.lambda > 0 && p.a > 0 &&
         p.min_relative_energy_change >= 0 && p.max_iterations >= 1 && p.control_points >= 1;
}

// Zero mean, unit RMS distance to the mean; false when non-finite or collapsed to a point.
bool normalise(const std::vector<cv::Point2f>& points, Points& out) {
  const auto n = static_cast<Eigen::Index>(points.size());
  out.resize(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& p = points[static_cast<std::size_t>(i)];
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
    out(i, 0) = p.x;
    out(i, 1) = p.y;
  }
  out.rowwise() -= out.colwise().mean();
  const double rms = std::sqrt(out.squaredNorm() / static_cast<double>(n));
  if (!(rms > 1e-9)) return false;
  out /= rms;
  return true;
}

// A seeded random subset of distinct positions (coincident control points would make the
// M-step singular). Uses the engine's raw output so the choice is the same on every platform.
std::vector<Eigen::Index> pick_control_points(const Points& x, int wanted, std::uint32_t seed) {
  const auto n = static_cast<std::size_t>(x.rows());
  std::vector<Eigen::Index> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<Eigen::Index>(i);
  std::mt19937 engine(seed);
  std::vector<Eigen::Index> chosen;
  for (std::size_t i = 0; i < n && chosen.size() < static_cast<std::size_t>(wanted); ++i) {
    std::swap(order[i], order[i + engine() % (n - i)]);
    const auto candidate = order[i];
    const bool duplicate = std::any_of(chosen.begin(), chosen.end(), [&](Eigen::Index c) {
      return (x.row(c) - x.row(candidate)).squaredNorm() < 1e-12;
    });
    if (!duplicate) chosen.push_back(candidate);
  }
  return chosen;
}

Eigen::MatrixXd gaussian_kernel(const Points& a, const Points& b, double beta) {
  Eigen::MatrixXd k(a.rows(), b.rows());
  for (Eigen::Index j = 0; j < b.rows(); ++j) {
    for (Eigen::Index i = 0; i < a.rows(); ++i) {
      k(i, j) = std::exp(-beta * (a.row(i) - b.row(j)).squaredNorm());
    }
  }
  return k;
}

}  // namespace

void validate(const VfcParams& p) {
  const auto fail = [](const std::string& what) { throw StartupError("VFC parameters: " + what); };
  if (!in_open_unit(p.gamma0)) fail("gamma0 must be in (0, 1), got " + std::to_string(p.gamma0));
  if (!in_open_unit(p.theta)) fail("theta must be in (0, 1), got " + std::to_string(p.theta));
  if (!(p.beta > 0)) fail("beta must be positive, got " + std::to_string(p.beta));
  if (!(p.lambda > 0)) fail("lambda must be positive, got " + std::to_string(p.lambda));
  if (!(p.a > 0)) fail("a must be positive, got " + std::to_string(p.a));
  if (!(p.min_relative_energy_change >= 0))
    fail("min_relative_energy_change must be >= 0, got " +
         std::to_string(p.min_relative_energy_change));
  if (p.max_iterations < 1)
    fail("max_iterations must be >= 1, got " + std::to_string(p.max_iterations));
  if (p.control_points < 1)
    fail("control_points must be >= 1, got " + std::to_string(p.control_points));
}

VfcResult sparse_vfc(const std::vector<cv::Point2f>& from, const std::vector<cv::Point2f>& to,
                     const VfcParams& params) {
  VfcResult result;
  if (from.size() != to.size() || from.size() < kMinMatches || !parameters_ok(params))
    return result;
  Points x, y;
  if (!normalise(from, x) || !normalise(to, y)) return result;
  y -= x;  // the field maps a position in image 1 to its displacement
  const auto n = x.rows();

  const auto control = pick_control_points(x, params.control_points, params.seed);
  Points xc(static_cast<Eigen::Index>(control.size()), 2);
  for (std::size_t j = 0; j < control.size(); ++j)
    xc.row(static_cast<Eigen::Index>(j)) = x.row(control[j]);
  const Eigen::MatrixXd u = gaussian_kernel(x, xc, params.beta);
  const Eigen::MatrixXd gram = gaussian_kernel(xc, xc, params.beta);

  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(xc.rows(), 2);
  Eigen::MatrixXd v = Eigen::MatrixXd::Zero(n, 2);
  Eigen::VectorXd p(n), residual(n);
  Eigen::MatrixXd weighted_u(n, xc.rows());
  double sigma2 = y.squaredNorm() / static_cast<double>(2 * n);
  double gamma = params.gamma0;
  double energy = 1.0;

  if (sigma2 < kMinSigma2) {  // every displacement equal: one translation explains all
    p.setOnes();
  } else {
    for (int iteration = 0; iteration < params.max_iterations; ++iteration) {
      // E-step: posterior of being an inlier (Gaussian around the field vs uniform outlier).
      residual = (y - v).rowwise().squaredNorm();
      const double outlier_density = 2.0 * kPi * sigma2 * (1.0 - gamma) / (gamma * params.a);
      p = (-residual.array() / (2.0 * sigma2)).exp();
      p = p.array() / (p.array() + outlier_density);
      const double sum_p = p.sum();
      const double previous = energy;
      energy = p.dot(residual) / (2.0 * sigma2) + sum_p * std::log(sigma2) -
               std::log(gamma) * sum_p - std::log(1.0 - gamma) * (static_cast<double>(n) - sum_p) +
               0.5 * params.lambda * (c.transpose() * gram * c).trace();
      result.iterations = iteration + 1;
      const double change = energy != 0.0 ? std::abs((energy - previous) / energy) : 0.0;
      if (iteration > 0 && change < params.min_relative_energy_change) break;

      // M-step on the sparse basis: (U^T P U + lambda s2 Gamma) C = U^T P Y.
      const Eigen::VectorXd w = p.cwiseMax(kMinPosterior);
      weighted_u = u.array().colwise() * w.array();
      Eigen::MatrixXd system = u.transpose() * weighted_u;
      system += params.lambda * sigma2 * gram;
      // The wide Gaussian kernel makes the system nearly singular; rounding can leave a pivot
      // slightly negative. A ridge far below the data's scale keeps the factorisation sound
      // without changing the fitted field.
      system.diagonal().array() += kRidge * system.diagonal().mean();
      const Eigen::MatrixXd rhs = weighted_u.transpose() * y;
      c = Eigen::LDLT<Eigen::MatrixXd>(system).solve(rhs);
      if (!c.allFinite()) return {};
      v.noalias() = u * c;
      sigma2 = w.dot((y - v).rowwise().squaredNorm()) / (2.0 * w.sum());
      const auto confident = (p.array() > params.theta).count();
      gamma = std::clamp(static_cast<double>(confident) / static_cast<double>(n), 0.05, 0.95);
      if (!std::isfinite(sigma2) || sigma2 < kMinSigma2) break;
    }
  }

  for (Eigen::Index i = 0; i < n; ++i) {
    if (p(i) > params.theta) result.inliers.push_back(static_cast<int>(i));
  }
  result.gamma = gamma;
  result.sigma2 = sigma2;
  return result;
}

}  // namespace keyfleet::station
