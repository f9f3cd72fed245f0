// Geometric verification cost against the number of putative matches (half of them uniform
// outliers): sparse VFC next to OpenCV's RANSAC. Prints figures; never pass/fail.
//   build/bin/bench_verification [--benchmark_repetitions=5
//   --benchmark_report_aggregates_only=true]
// Matches: a 640x480 view pair related by a homography (a smooth field for VFC, an exact
// model for RANSAC-H) with 0.5 px noise; RANSAC-F gets a rigid 3D scene instead, since a
// plane is degenerate for the fundamental matrix.
#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "keyfleet/station/geometry/match_verifier.hpp"
#include "keyfleet/station/geometry/vfc.hpp"

namespace {

namespace station = keyfleet::station;

struct Matches {
  std::vector<cv::Point2f> from, to;
};

// Every other match is an outlier with independent uniform ends.
template <typename Motion>
Matches make_matches(std::size_t count, unsigned seed, Motion motion) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  Matches m;
  while (m.from.size() < count) {
    if (m.from.size() % 2 == 0) {
      cv::Point2f p, q;
      if (!motion(rng, p, q)) continue;
      m.from.push_back(p);
      m.to.push_back(q);
    } else {
      m.from.emplace_back(ux(rng), uy(rng));
      m.to.emplace_back(ux(rng), uy(rng));
    }
  }
  return m;
}

Matches homography_matches(std::size_t count) {
  const cv::Matx33d h(1.08, 0.06, -30, -0.05, 1.1, 12, 1e-4, -5e-5, 1);
  std::normal_distribution<float> noise(0, 0.5f);
  std::uniform_real_distribution<float> ux(0, 640), uy(0, 480);
  return make_matches(count, 7, [&](std::mt19937& rng, cv::Point2f& p, cv::Point2f& q) {
    p = {ux(rng), uy(rng)};
    const cv::Vec3d moved = h * cv::Vec3d(p.x, p.y, 1);
    q = {float(moved[0] / moved[2]) + noise(rng), float(moved[1] / moved[2]) + noise(rng)};
    return true;
  });
}

Matches rigid_scene_matches(std::size_t count) {
  std::uniform_real_distribution<double> lateral(-2, 2), depth(4, 9);
  std::normal_distribution<double> noise(0, 0.5);
  const double f = 500, cx = 320, cy = 240, yaw = 0.1;
  return make_matches(count, 9, [&](std::mt19937& rng, cv::Point2f& p, cv::Point2f& q) {
    const double x = lateral(rng), y = 0.75 * lateral(rng), z = depth(rng);
    const double x2 = std::cos(yaw) * x - std::sin(yaw) * z - 0.6;
    const double z2 = std::sin(yaw) * x + std::cos(yaw) * z;
    p = {float(f * x / z + cx + noise(rng)), float(f * y / z + cy + noise(rng))};
    q = {float(f * x2 / z2 + cx + noise(rng)), float(f * y / z2 + cy + noise(rng))};
    return p.x >= 0 && p.x < 640 && p.y >= 0 && p.y < 480 && q.x >= 0 && q.x < 640 && q.y >= 0 &&
           q.y < 480;
  });
}

void report(benchmark::State& state, std::size_t inliers) {
  state.counters["inliers"] = static_cast<double>(inliers);
  state.counters["truth"] = static_cast<double>(state.range(0) / 2);
}

void BM_SparseVfc(benchmark::State& state) {
  const auto m = homography_matches(static_cast<std::size_t>(state.range(0)));
  station::VfcResult result;
  for (auto _ : state) {
    result = station::sparse_vfc(m.from, m.to);
    benchmark::DoNotOptimize(result.inliers.data());
  }
  report(state, result.inliers.size());
  state.counters["em_iterations"] = result.iterations;
}

void run_verifier(benchmark::State& state, const Matches& m, station::VerifierKind kind,
                  bool usac) {
  station::RansacParams params;
  params.usac = usac;
  const auto verifier = station::make_match_verifier(kind, {}, params);
  station::Verification v;
  for (auto _ : state) {
    v = verifier->verify(m.from, m.to);
    benchmark::DoNotOptimize(v.inliers.data());
  }
  report(state, v.inliers.size());
}

void BM_UsacHomography(benchmark::State& state) {
  run_verifier(state, homography_matches(static_cast<std::size_t>(state.range(0))),
               station::VerifierKind::kRansacHomography, true);
}

void BM_ClassicRansacHomography(benchmark::State& state) {
  run_verifier(state, homography_matches(static_cast<std::size_t>(state.range(0))),
               station::VerifierKind::kRansacHomography, false);
}

void BM_UsacFundamental(benchmark::State& state) {
  run_verifier(state, rigid_scene_matches(static_cast<std::size_t>(state.range(0))),
               station::VerifierKind::kRansacFundamental, true);
}

void BM_ClassicRansacFundamental(benchmark::State& state) {
  run_verifier(state, rigid_scene_matches(static_cast<std::size_t>(state.range(0))),
               station::VerifierKind::kRansacFundamental, false);
}

void match_counts(benchmark::internal::Benchmark* b) {
  for (int n : {100, 250, 500, 1000, 2000}) b->Arg(n);
  b->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_SparseVfc)->Apply(match_counts);
BENCHMARK(BM_UsacHomography)->Apply(match_counts);
BENCHMARK(BM_ClassicRansacHomography)->Apply(match_counts);
BENCHMARK(BM_UsacFundamental)->Apply(match_counts);
BENCHMARK(BM_ClassicRansacFundamental)->Apply(match_counts);

}  // namespace

BENCHMARK_MAIN();
