// Fig. 6 over several seeds: means and 95 % intervals on hand-made numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/seed_aggregate.hpp"
#include "test_support.hpp"

namespace keyfleet::eval {
namespace {

TEST(MeanInterval, StudentTIntervalOfTheMean) {
  // Mean 4, sample sd 2 (values 2, 4, 6), t(0.975, 2) = 4.303: half-width 4.303 * 2 / sqrt(3).
  const Interval i = mean_interval({2, 4, 6});
  EXPECT_EQ(i.n, 3u);
  EXPECT_DOUBLE_EQ(i.mean, 4.0);
  const double half = 4.303 * 2.0 / std::sqrt(3.0);
  EXPECT_NEAR(i.low, 4.0 - half, 1e-9);
  EXPECT_NEAR(i.high, 4.0 + half, 1e-9);
}

TEST(MeanInterval, OneSampleHasNoSpreadAndNoneIsEmpty) {
  const Interval one = mean_interval({7.5});
  EXPECT_EQ(one.n, 1u);
  EXPECT_DOUBLE_EQ(one.low, 7.5);
  EXPECT_DOUBLE_EQ(one.high, 7.5);
  const Interval none = mean_interval({});
  EXPECT_EQ(none.n, 0u);
  EXPECT_DOUBLE_EQ(none.mean, 0.0);
}

TEST(MeanInterval, IdenticalSamplesGiveAPointAndMoreSamplesANarrowerInterval) {
  const Interval same = mean_interval({3, 3, 3, 3});
  EXPECT_DOUBLE_EQ(same.low, 3.0);
  EXPECT_DOUBLE_EQ(same.high, 3.0);
  const Interval few = mean_interval({1, 3});
  const Interval many = mean_interval({1, 3, 1, 3, 1, 3, 1, 3});
  EXPECT_LT(many.high - many.low, few.high - few.low);
}

TEST(StudentT, TableEndsAtTheNormalQuantile) {
  EXPECT_DOUBLE_EQ(student_t_975(1), 12.706);
  EXPECT_DOUBLE_EQ(student_t_975(10), 2.228);
  EXPECT_DOUBLE_EQ(student_t_975(1000), 1.960);
  for (std::size_t d = 1; d < 200; ++d) EXPECT_GE(student_t_975(d), student_t_975(d + 1));
}

PointSummary point(const std::string& strategy, double density, std::size_t read, std::size_t full,
                   std::size_t top1_of_10) {
  PointSummary p;
  p.strategy = strategy;
  p.density = density;
  p.words_read = read;
  p.full_words = full;
  p.words_in_sequence = 20;
  p.keyframes = 8;
  p.topk.queries = 10;
  p.topk.top1 = top1_of_10;
  p.topk.top5 = 10;
  return p;
}

EvalResults run(std::vector<PointSummary> summary) {
  EvalResults r;
  r.summary = std::move(summary);
  return r;
}

TEST(AggregateSeeds, OnePointPerStrategyAndDensityOverTheSeeds) {
  const std::vector<EvalResults> runs = {
      run({point("vslam", 0.5, 4, 10, 7), point("full", 0.5, 6, 12, 8)}),
      run({point("vslam", 0.5, 6, 10, 9), point("full", 0.5, 8, 14, 8)}),
  };
  const auto points = aggregate_seeds(runs);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].strategy, "vslam");
  EXPECT_DOUBLE_EQ(points[0].words_read.mean, 5.0);
  EXPECT_DOUBLE_EQ(points[0].top1.mean, 0.8);
  EXPECT_EQ(points[1].strategy, "full");
  EXPECT_DOUBLE_EQ(points[1].words_read.mean, 7.0);
  EXPECT_DOUBLE_EQ(points[1].full_words.mean, 13.0);
  EXPECT_EQ(points[1].words_read.n, 2u);
  // Paired with vslam on each seed: full read 2 more both times, top-1 +0.1 then -0.1.
  EXPECT_DOUBLE_EQ(points[1].words_read_vs_vslam.mean, 2.0);
  EXPECT_DOUBLE_EQ(points[1].words_read_vs_vslam.low, 2.0);
  EXPECT_NEAR(points[1].top1_vs_vslam.mean, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(points[0].words_read_vs_vslam.mean, 0.0);
  // Two samples 6 and 8: sd sqrt(2), t(0.975, 1) = 12.706.
  EXPECT_NEAR(points[1].words_read.high - 7.0, 12.706 * std::sqrt(2.0) / std::sqrt(2.0), 1e-9);
}

TEST(AggregateSeeds, ARunWithoutAPointDoesNotCountForIt) {
  const std::vector<EvalResults> runs = {run({point("full", 0.2, 3, 5, 5)}),
                                         run({point("full", 0.5, 9, 9, 9)})};
  const auto points = aggregate_seeds(runs);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].words_read.n, 1u);
  EXPECT_DOUBLE_EQ(points[0].words_read.mean, 3.0);
  EXPECT_TRUE(aggregate_seeds({}).empty());
}

TEST(AggregateSeeds, ASummaryWrittenByAnEvaluationReadsBackAsWritten) {
  keyfleet::test::TempDir dir;
  EvalResults written = run({point("vslam", 0.5, 4, 10, 7), point("full", 0.5, 6, 12, 8)});
  written.strategies = {"vslam", "full"};
  written.densities = {0.5};
  write_results(written, dir.path().string());
  const auto read = read_summary((dir.path() / "results.json").string());
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[1].strategy, "full");
  EXPECT_DOUBLE_EQ(read[1].density, 0.5);
  EXPECT_EQ(read[1].words_read, 6u);
  EXPECT_EQ(read[1].full_words, 12u);
  EXPECT_EQ(read[1].topk.queries, 10u);
  EXPECT_EQ(read[1].topk.top1, 8u);
  EXPECT_EQ(read[1].topk.top5, 10u);
  EXPECT_THROW(read_summary((dir.path() / "missing.json").string()), StartupError);
}

TEST(AggregateSeeds, WritesJsonCsvAndMarkdown) {
  keyfleet::test::TempDir dir;
  const auto points =
      aggregate_seeds({run({point("full", 0.5, 6, 12, 8)}), run({point("full", 0.5, 8, 14, 8)})});
  write_seed_results(points, {3, 4}, dir.path().string());
  for (const char* name : {"seeds.json", "seeds.csv", "seeds.md"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir.path() / name)) << name;
  std::ifstream md(dir.path() / "seeds.md");
  std::stringstream text;
  text << md.rdbuf();
  EXPECT_NE(text.str().find("| full | 50 % |"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("7.0 ["), std::string::npos) << text.str();
}

}  // namespace
}  // namespace keyfleet::eval
