#pragma once
// Fig. 6 over several generated streets: one evaluation per scenario seed, then per strategy
// and density the mean and a 95 % interval of each measure over the seeds. One run of one seed
// is noise; claims are judged on the intervals.
#include <cstddef>
#include <string>
#include <vector>

#include "keyfleet/eval/eval_runner.hpp"

namespace keyfleet::eval {

struct Interval {
  std::size_t n = 0;  // samples
  double mean = 0;
  // Student's t interval of the mean at 95 %: mean -+ t(0.975, n-1) s / sqrt(n); low = high =
  // mean for a single sample (no spread can be estimated from one).
  double low = 0, high = 0;
};

Interval mean_interval(const std::vector<double>& samples);

// The two-sided 97.5 % quantile of Student's t with `degrees` degrees of freedom (>= 1).
double student_t_975(std::size_t degrees);

struct SeedPoint {
  std::string strategy;
  double density = 1;
  Interval words_read, full_words, words_in_sequence;  // distinct signs, summed over drones
  Interval word_recall, top1, top5;                    // rates in [0, 1]
  Interval keyframes;
  // Paired with the V-SLAM baseline at the same density on the same seed: this strategy's
  // value minus vslam's, so that the street's own difficulty cancels (n = 0 when the runs hold
  // no vslam point).
  Interval words_read_vs_vslam, top1_vs_vslam;
};

// Per (strategy, density) over the runs (one per seed), in the order of the first run's summary.
// Runs missing a point do not contribute to it.
std::vector<SeedPoint> aggregate_seeds(const std::vector<EvalResults>& runs);

// seeds.json, seeds.csv and seeds.md in out_dir: the intervals, and which seeds went in.
void write_seed_results(const std::vector<SeedPoint>& points,
                        const std::vector<std::uint64_t>& seeds, const std::string& out_dir);

}  // namespace keyfleet::eval
