// A short `keyfleet eval` on a tiny generated scenario (2 drones on 2 days, 2 strategies,
// 2 densities): the output files exist and the figures are in sane ranges.
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include "keyfleet/common/config_error.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/eval_runner.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

TEST(EvalConfig, RejectsWhatCannotBeEvaluated) {
  const std::string scenario = "scenario_dir: /nonexistent\n";
  EXPECT_NO_THROW(parse_eval_config(scenario + "densities: [1.0, 0.1]\n", "ok"));
  EXPECT_THROW(parse_eval_config(scenario + "densities: [0.5, 0]\n", "zero"), ConfigError);
  EXPECT_THROW(parse_eval_config(scenario + "densities: [1.5]\n", "above one"), ConfigError);
  EXPECT_THROW(parse_eval_config(scenario + "strategies: [vslam, best]\n", "unknown"), ConfigError);
  EXPECT_THROW(parse_eval_config(scenario + "query_every: 0\n", "no queries"), ConfigError);
  const EvalConfig defaults = parse_eval_config(scenario, "defaults");
  EXPECT_EQ(defaults.strategies.size(), 4u);
  EXPECT_EQ(defaults.densities.size(), 6u);
}

TEST(EvalRun, TinyScenarioGivesFilesAndSaneFigures) {
  const fs::path out = fs::temp_directory_path() / ("keyfleet-eval-" + std::to_string(::getpid()));
  fs::remove_all(out);
  EvalConfig config = parse_eval_config(R"(
scenario:
  name: tiny
  seed: 3
  frames_per_drone: 40
  width: 320
  height: 240
  street: {length_m: 40}
  textures:
    # One font folder: whatever else is installed (symbol fonts) must not matter here.
    font_folders: [/usr/share/fonts/truetype/dejavu]
  drones: {count: 2, days: 2}
strategies: [vslam, quality]
densities: [1.0, 0.5]
query_every: 5
)",
                                        "tiny eval");
  const std::string scenario = prepare_scenario(config, out.string(), null_logger());
  const EvalResults r = run_eval(config, scenario, null_logger());
  write_results(r, out.string());

  for (const char* file : {"results.json", "results.csv", "report.md"})
    EXPECT_GT(fs::file_size(out / file), 100u) << file;
  std::ifstream in(out / "results.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j["summary"].size(), 4u);
  EXPECT_EQ(j["words"].size(), 8u);    // 2 drones x 2 strategies x 2 densities
  EXPECT_EQ(j["places"].size(), 24u);  // 2 ordered pairs x 2 x 2, per retrieval (bow, cnn, fusion)
  ASSERT_EQ(r.summary_by_retrieval.size(), 3u);
  for (const char* mode : {"bow", "cnn", "fusion"}) {
    ASSERT_EQ(r.summary_by_retrieval.at(mode).size(), 4u) << mode;
    for (const auto& p : r.summary_by_retrieval.at(mode)) {
      EXPECT_LE(p.topk.top1, p.topk.top5) << mode;
      EXPECT_EQ(p.topk.queries, r.summary.front().topk.queries) << mode;  // the same queries
    }
  }

  ASSERT_EQ(r.summary.size(), 4u);
  for (const auto& p : r.summary) {
    EXPECT_GT(p.keyframes, 0u);
    EXPECT_LE(p.keyframes, p.vslam_keyframes);
    EXPECT_GT(p.bytes, 0u);
    EXPECT_GE(p.word_recall, 0.0);
    EXPECT_LE(p.word_recall, 1.0);
    EXPECT_LE(p.full_words, p.words_in_sequence);
    EXPECT_LE(p.words_read, p.words_in_sequence);
    EXPECT_LE(p.topk.top1, p.topk.top5);
    EXPECT_LE(p.topk.top5, p.topk.queries);
    EXPECT_GT(p.topk.queries, 0u);
  }
  // Same density, same number of keyframes sent, whatever the strategy; fewer when thinned.
  EXPECT_EQ(r.summary[0].keyframes, r.summary[2].keyframes);
  EXPECT_EQ(r.summary[1].keyframes, r.summary[3].keyframes);
  EXPECT_LT(r.summary[1].keyframes, r.summary[0].keyframes);
  EXPECT_LT(r.summary[1].bytes, r.summary[0].bytes);
  EXPECT_EQ(r.cost.frames, 80u);
  EXPECT_GT(r.cost.ocr_frames, 0u);
  fs::remove_all(out);
}

}  // namespace
}  // namespace keyfleet::eval
