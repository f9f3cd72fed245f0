// Sparse VFC and the RANSAC baseline against ground truth: a synthetic smooth motion field
// with uniform outliers, and ORB matches on the real 'churchill' homography views.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/station/geometry/match_verifier.hpp"
#include "keyfleet/station/geometry/vfc.hpp"
#include "test_support.hpp"

namespace {

using keyfleet::station::make_match_verifier;
using keyfleet::station::sparse_vfc;
using keyfleet::station::VerifierKind;

struct Matches {
  std::vector<cv::Point2f> from, to;
  std::vector<bool> truth;  // true = the match agrees with the ground-truth motion
};

struct Score {
  double precision = 0, recall = 0;
  double f1() const {
    return precision + recall > 0 ? 2 * precision * recall / (precision + recall) : 0;
  }
};

Score score(const std::vector<int>& found, const std::vector<bool>& truth) {
  std::size_t true_positives = 0, positives = 0;
  for (int i : found) true_positives += truth[static_cast<std::size_t>(i)] ? 1 : 0;
  for (bool t : truth) positives += t ? 1 : 0;
  Score s;
  s.precision = found.empty() ? 0 : double(true_positives) / double(found.size());
  s.recall = positives == 0 ? 0 : double(true_positives) / double(positives);
  return s;
}

// Appends correspondences with independent uniform ends until outliers make up `ratio`.
void add_uniform_outliers(Matches& m, double ratio, cv::Size from_size, cv::Size to_size,
                          unsigned seed) {
  std::size_t inliers = 0;
  for (bool t : m.truth) inliers += t ? 1 : 0;
  const auto total = static_cast<std::size_t>(std::lround(double(inliers) / (1.0 - ratio)));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> fx(0, float(from_size.width)),
      fy(0, float(from_size.height));
  std::uniform_real_distribution<float> tx(0, float(to_size.width)), ty(0, float(to_size.height));
  while (m.from.size() < total) {
    m.from.emplace_back(fx(rng), fy(rng));
    m.to.emplace_back(tx(rng), ty(rng));
    m.truth.push_back(false);
  }
}

// A smooth non-rigid motion on a 640x480 image: rotation, zoom, shift and a gentle bend,
// plus 0.5 px Gaussian noise on the inliers.
Matches synthetic_field(std::size_t inliers, double outlier_ratio, unsigned seed) {
  Matches m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  std::normal_distribution<float> noise(0, 0.5f);
  const float angle = 0.08f, zoom = 1.1f;
  for (std::size_t i = 0; i < inliers; ++i) {
    const cv::Point2f p(ux(rng), uy(rng));
    const cv::Point2f c = p - cv::Point2f(320, 240);
    const cv::Point2f q(zoom * (std::cos(angle) * c.x - std::sin(angle) * c.y) + 335 +
                            12 * std::sin(p.y / 120.0f) + noise(rng),
                        zoom * (std::sin(angle) * c.x + std::cos(angle) * c.y) + 230 +
                            8 * std::cos(p.x / 150.0f) + noise(rng));
    m.from.push_back(p);
    m.to.push_back(q);
    m.truth.push_back(true);
  }
  add_uniform_outliers(m, outlier_ratio, {640, 480}, {640, 480}, seed + 1);
  // Shuffle so that inliers are not a prefix (control points and RANSAC see a mixed set).
  std::vector<std::size_t> order(m.from.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  Matches shuffled;
  for (std::size_t i : order) {
    shuffled.from.push_back(m.from[i]);
    shuffled.to.push_back(m.to[i]);
    shuffled.truth.push_back(m.truth[i]);
  }
  return shuffled;
}

TEST(SparseVfc, RecoversASmoothFieldUnderHalfOutliers) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const auto m = synthetic_field(500, 0.5, seed);
    const auto result = sparse_vfc(m.from, m.to);
    const auto s = score(result.inliers, m.truth);
    std::cout << "synthetic 50% outliers seed " << seed << ": precision " << s.precision
              << " recall " << s.recall << " iterations " << result.iterations << " gamma "
              << result.gamma << "\n";
    // Measured: precision >= 0.998, recall 1.0 over these seeds.
    EXPECT_GE(s.precision, 0.98) << "seed " << seed;
    EXPECT_GE(s.recall, 0.98) << "seed " << seed;
  }
}

TEST(SparseVfc, RecoversASmoothFieldUnderNinetyPercentOutliers) {
  const auto m = synthetic_field(300, 0.9, 7);
  const auto result = sparse_vfc(m.from, m.to);
  const auto s = score(result.inliers, m.truth);
  std::cout << "synthetic 90% outliers: precision " << s.precision << " recall " << s.recall
            << " iterations " << result.iterations << "\n";
  // Measured: precision 0.993, recall 1.0.
  EXPECT_GE(s.precision, 0.95);
  EXPECT_GE(s.recall, 0.95);
}

TEST(SparseVfc, IsDeterministic) {
  const auto m = synthetic_field(400, 0.6, 11);
  const auto first = sparse_vfc(m.from, m.to);
  const auto second = sparse_vfc(m.from, m.to);
  EXPECT_FALSE(first.inliers.empty());
  EXPECT_EQ(first.inliers, second.inliers);
  EXPECT_EQ(first.iterations, second.iterations);
  EXPECT_EQ(first.sigma2, second.sigma2);
  for (auto kind : {VerifierKind::kRansacHomography, VerifierKind::kRansacFundamental}) {
    const auto verifier = make_match_verifier(kind);
    EXPECT_EQ(verifier->verify(m.from, m.to).inliers, verifier->verify(m.from, m.to).inliers)
        << verifier->name();
  }
}

TEST(SparseVfc, DegenerateInputsGiveAnEmptyResult) {
  const auto m = synthetic_field(50, 0.2, 5);
  const std::vector<cv::Point2f> few(m.from.begin(), m.from.begin() + 7);
  const std::vector<cv::Point2f> few_to(m.to.begin(), m.to.begin() + 7);
  EXPECT_TRUE(sparse_vfc(few, few_to).inliers.empty());
  EXPECT_TRUE(sparse_vfc({}, {}).inliers.empty());
  EXPECT_TRUE(sparse_vfc(m.from, few_to).inliers.empty());  // sizes differ

  const std::vector<cv::Point2f> same(40, cv::Point2f(10, 20));
  EXPECT_TRUE(sparse_vfc(same, m.to).inliers.empty());
  EXPECT_TRUE(sparse_vfc(m.from, same).inliers.empty());

  auto with_nan = m.from;
  with_nan[3].x = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(sparse_vfc(with_nan, m.to).inliers.empty());
  auto with_inf = m.to;
  with_inf[0].y = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(sparse_vfc(m.from, with_inf).inliers.empty());

  keyfleet::station::VfcParams bad;
  bad.theta = 1.5;
  EXPECT_TRUE(sparse_vfc(m.from, m.to, bad).inliers.empty());

  for (auto kind :
       {VerifierKind::kVfc, VerifierKind::kRansacHomography, VerifierKind::kRansacFundamental}) {
    const auto verifier = make_match_verifier(kind);
    EXPECT_TRUE(verifier->verify(few, few_to).inliers.empty()) << verifier->name();
    EXPECT_TRUE(verifier->verify(with_nan, m.to).inliers.empty()) << verifier->name();
    EXPECT_TRUE(verifier->verify(same, same).inliers.empty()) << verifier->name();
    EXPECT_TRUE(verifier->verify(m.from, few_to).inliers.empty()) << verifier->name();
  }
}

TEST(SparseVfc, ASimilarityIsAllInliers) {
  std::vector<cv::Point2f> from, to;
  for (int i = 0; i < 30; ++i) {
    from.emplace_back(float(i * 7 % 50), float(i * 13 % 40));
    to.push_back(from.back() * 2.0f + cv::Point2f(5, -3));
  }
  EXPECT_EQ(sparse_vfc(from, to).inliers.size(), from.size());
}

TEST(MatchVerifier, ParsesKindsAndRejectsUnknownOnes) {
  EXPECT_EQ(keyfleet::station::parse_verifier_kind("vfc"), VerifierKind::kVfc);
  EXPECT_EQ(keyfleet::station::parse_verifier_kind("ransac_homography"),
            VerifierKind::kRansacHomography);
  EXPECT_EQ(keyfleet::station::parse_verifier_kind("ransac_fundamental"),
            VerifierKind::kRansacFundamental);
  EXPECT_THROW(keyfleet::station::parse_verifier_kind("ransac"), keyfleet::StartupError);
  keyfleet::station::VfcParams bad_vfc;
  bad_vfc.gamma0 = 0;
  EXPECT_THROW(make_match_verifier(VerifierKind::kVfc, bad_vfc), keyfleet::StartupError);
  keyfleet::station::RansacParams bad_ransac;
  bad_ransac.confidence = 1.0;
  EXPECT_THROW(make_match_verifier(VerifierKind::kRansacHomography, {}, bad_ransac),
               keyfleet::StartupError);
  EXPECT_EQ(make_match_verifier(VerifierKind::kVfc)->name(), "vfc");
}

// Two views of a random 3D point cloud: a rigid scene, so the fundamental matrix holds
// for every inlier and the RANSAC verifiers have something true to find.
Matches two_view_scene(std::size_t inliers, double outlier_ratio, unsigned seed) {
  Matches m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-2, 2), depth(4, 9);
  std::normal_distribution<double> noise(0, 0.3);
  const double f = 500, cx = 320, cy = 240, yaw = 0.1;
  while (m.from.size() < inliers) {
    const double x = lateral(rng), y = 0.75 * lateral(rng), z = depth(rng);
    // Camera 2: turned by `yaw` about the vertical axis and moved 0.6 to the right.
    const double x2 = std::cos(yaw) * x - std::sin(yaw) * z - 0.6;
    const double z2 = std::sin(yaw) * x + std::cos(yaw) * z;
    const cv::Point2f p(float(f * x / z + cx + noise(rng)), float(f * y / z + cy + noise(rng)));
    const cv::Point2f q(float(f * x2 / z2 + cx + noise(rng)), float(f * y / z2 + cy + noise(rng)));
    if (p.x < 0 || p.x > 640 || p.y < 0 || p.y > 480 || q.x < 0 || q.x > 640 || q.y < 0 ||
        q.y > 480)
      continue;
    m.from.push_back(p);
    m.to.push_back(q);
    m.truth.push_back(true);
  }
  add_uniform_outliers(m, outlier_ratio, {640, 480}, {640, 480}, seed + 1);
  return m;
}

TEST(MatchVerifier, RansacFundamentalFindsARigidScene) {
  const auto m = two_view_scene(300, 0.5, 21);
  const auto verifier = make_match_verifier(VerifierKind::kRansacFundamental);
  const auto v = verifier->verify(m.from, m.to);
  const auto s = score(v.inliers, m.truth);
  EXPECT_EQ(v.candidates, m.from.size());
  EXPECT_NEAR(v.inlier_ratio(), double(v.inliers.size()) / double(m.from.size()), 1e-12);
  // An outlier can lie near its epipolar line by chance, so precision is below 1.
  EXPECT_GE(s.recall, 0.9);
  EXPECT_GE(s.precision, 0.85);
}

TEST(MatchVerifier, VfcVerifierWrapsSparseVfc) {
  const auto m = synthetic_field(400, 0.5, 31);
  const auto vfc = make_match_verifier(VerifierKind::kVfc)->verify(m.from, m.to);
  EXPECT_EQ(vfc.inliers, sparse_vfc(m.from, m.to).inliers);
  EXPECT_NEAR(vfc.inlier_ratio(), 0.5, 0.02);
  EXPECT_EQ(keyfleet::station::Verification{}.inlier_ratio(), 0.0);
}

// ORB (1500 features) with plain nearest-neighbour Hamming matching, no ratio test or
// cross-check, so that the natural outliers stay. Ground truth: H_1_k moves the point in
// image 1 to within 5 px of its match in image k.
Matches churchill_matches(const std::filesystem::path& dir, int k, cv::Size* size_k = nullptr) {
  const cv::Mat first = cv::imread((dir / "1.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat other =
      cv::imread((dir / (std::to_string(k) + ".png")).string(), cv::IMREAD_GRAYSCALE);
  cv::Mat h(3, 3, CV_64F);
  std::ifstream file(dir / ("H_1_" + std::to_string(k)));
  for (int i = 0; i < 9; ++i) file >> h.at<double>(i / 3, i % 3);
  if (first.empty() || other.empty() || !file)
    throw std::runtime_error("churchill data unreadable");
  if (size_k) *size_k = other.size();

  auto orb = cv::ORB::create(1500);
  std::vector<cv::KeyPoint> kp1, kp2;
  cv::Mat d1, d2;
  orb->detectAndCompute(first, cv::noArray(), kp1, d1);
  orb->detectAndCompute(other, cv::noArray(), kp2, d2);
  std::vector<cv::DMatch> nn;
  cv::BFMatcher(cv::NORM_HAMMING).match(d1, d2, nn);

  Matches m;
  for (const auto& match : nn) {
    m.from.push_back(kp1[static_cast<std::size_t>(match.queryIdx)].pt);
    m.to.push_back(kp2[static_cast<std::size_t>(match.trainIdx)].pt);
  }
  std::vector<cv::Point2f> mapped;
  cv::perspectiveTransform(m.from, mapped, h);
  for (std::size_t i = 0; i < mapped.size(); ++i)
    m.truth.push_back(cv::norm(mapped[i] - m.to[i]) < 5.0);
  return m;
}

// VFC keeps nearly every true match; its 'false' inliers are almost all 5-12 px from the
// ground truth (ORB corners from coarse pyramid levels, magnified by the 2-3x zoom of
// views 2-3), so its precision at a strict 5 px reads lower than RANSAC's at 3 px.
TEST(SparseVfcRealData, ChurchillOrbMatches) {
  KEYFLEET_REQUIRE_DATA("homography/churchill");
  const auto ransac = make_match_verifier(VerifierKind::kRansacHomography);
  // Floors per view, about 0.1 below what was measured (OpenCV 4.6, 1500 ORB features):
  // precision 0.92 / 0.84 / 0.79 / 1.00 / 0.65, recall 0.998 / 1.0 / 0.995 / 0.998 / 0.87
  // for views 2..6 (natural outliers 40 / 61 / 75 / 16 / 90 %).
  const double precision_floor[] = {0.8, 0.72, 0.68, 0.9, 0.5};
  const double recall_floor[] = {0.9, 0.9, 0.9, 0.9, 0.75};
  for (int k = 2; k <= 6; ++k) {
    const auto m = churchill_matches(data_path, k);
    const auto vin = sparse_vfc(m.from, m.to).inliers;
    const auto s = score(vin, m.truth);
    const auto r = score(ransac->verify(m.from, m.to).inliers, m.truth);
    std::size_t positives = 0;
    for (bool t : m.truth) positives += t ? 1 : 0;
    std::cout << "churchill 1->" << k << ": " << m.from.size() << " matches, "
              << 100.0 * (1.0 - double(positives) / double(m.from.size())) << "% outliers; VFC P "
              << s.precision << " R " << s.recall << " F1 " << s.f1() << "; RANSAC-H P "
              << r.precision << " R " << r.recall << " F1 " << r.f1() << "\n";
    EXPECT_GE(s.precision, precision_floor[k - 2]) << "view " << k;
    EXPECT_GE(s.recall, recall_floor[k - 2]) << "view " << k;
    // Measured: VFC's F1 is within 0.006 of RANSAC's or above it on every view.
    EXPECT_GE(s.f1(), r.f1() - 0.05) << "view " << k;
  }
}

TEST(SparseVfcRealData, HoldsUpAgainstRansacAtHighOutlierRatios) {
  KEYFLEET_REQUIRE_DATA("homography/churchill");
  const auto ransac = make_match_verifier(VerifierKind::kRansacHomography);
  for (int k : {2, 3, 5}) {
    cv::Size size_k;
    const auto base = churchill_matches(data_path, k, &size_k);
    for (double ratio : {0.7, 0.9}) {
      auto m = base;
      add_uniform_outliers(m, ratio, {768, 1024}, size_k, 100u + unsigned(k));
      const auto s = score(sparse_vfc(m.from, m.to).inliers, m.truth);
      const auto r = score(ransac->verify(m.from, m.to).inliers, m.truth);
      std::cout << "churchill 1->" << k << " at " << ratio * 100 << "% outliers (" << m.from.size()
                << " matches): VFC P " << s.precision << " R " << s.recall << " F1 " << s.f1()
                << "; RANSAC-H P " << r.precision << " R " << r.recall << " F1 " << r.f1() << "\n";
      // Measured VFC F1: 0.90-0.99 at 70 %, 0.89-0.98 at 90 % (RANSAC-H with 2000
      // iterations finds nothing at 90 %).
      EXPECT_GE(s.f1(), 0.8) << "view " << k << " at " << ratio;
      EXPECT_GE(s.f1(), r.f1() - 0.05) << "view " << k << " at " << ratio;
    }
  }
}

}  // namespace
