// `keyfleet eval CONFIG [--out DIR]`: Fig. 6 of Alonso et al. (ICRA 2019) (words read and place
// recognition against the share of V-SLAM keyframes kept) on a generated scenario.
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/eval_runner.hpp"
#include "keyfleet/eval/seed_aggregate.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

struct EvalOptions {
  std::string config;
  std::string out;
  std::string scenario_dir;
  std::string python = "/usr/bin/python3";
  std::vector<std::uint64_t> seeds;  // several generated streets, one evaluation each
};

std::string default_out() {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
  return std::string("runs/eval-") + stamp;
}

void print_summary(const eval::EvalResults& r) {
  const bool encodings = !r.encodings.empty();
  std::printf("\n%s%-9s %6s %5s %11s %11s %7s %7s %9s\n", encodings ? "encoding     " : "",
              "strategy", "kept", "kf", "words read", "words full", "top-1", "top-5", "MB sent");
  for (const auto& p : r.summary) {
    if (encodings) std::printf("%-12s ", p.encoding.c_str());
    std::printf("%-9s %5.0f%% %5zu %5zu/%-5zu %5zu/%-5zu %7.3f %7.3f %9.2f\n", p.strategy.c_str(),
                100 * p.density, p.keyframes, p.words_read, p.words_in_sequence, p.full_words,
                p.words_in_sequence, p.topk.top1_rate(), p.topk.top5_rate(), p.bytes / 1e6);
  }
  if (!encodings) return;
  // Issue 30: information per byte, each encoding against the first.
  std::printf("\n%-12s %-9s %6s %8s %11s %7s", "encoding", "strategy", "kept", "kB/kf",
              "words read", ("% " + r.encodings.front().name).c_str());
  for (const auto& mode : r.place_retrievals) std::printf(" %12s", ("top-1 " + mode).c_str());
  std::printf("\n");
  for (const auto& p : eval::compare_encodings(r)) {
    std::printf("%-12s %-9s %5.0f%% %8.1f %5zu/%-5zu %6.1f%%", p.encoding.c_str(),
                p.strategy.c_str(), 100 * p.density, p.kb_per_keyframe, p.words_read,
                p.words_in_sequence, 100 * p.words_vs_reference);
    for (const auto& mode : r.place_retrievals) {
      const auto it = p.top1.find(mode);
      std::printf(" %12.3f", it == p.top1.end() ? 0.0 : it->second);
    }
    std::printf("\n");
  }
}

void print_seed_summary(const std::vector<eval::SeedPoint>& points, std::size_t seeds) {
  std::printf("\nover %zu seeds: mean [95 %% interval]\n%-9s %6s %-22s %-22s %-22s\n", seeds,
              "strategy", "kept", "words read", "words full", "top-1 %");
  for (const auto& p : points)
    std::printf("%-9s %5.0f%% %6.1f [%5.1f, %5.1f]   %6.1f [%5.1f, %5.1f]   %5.1f [%5.1f, %5.1f]\n",
                p.strategy.c_str(), 100 * p.density, p.words_read.mean, p.words_read.low,
                p.words_read.high, p.full_words.mean, p.full_words.low, p.full_words.high,
                100 * p.top1.mean, 100 * p.top1.low, 100 * p.top1.high);
}

// One evaluation per seed in <out>/seed-<n>/ (its own generated street), then the intervals.
// A seed whose results.json is there already is not run again, so a stopped run resumes.
void run_seeds(const EvalConfig& base, const EvalOptions& o, const std::string& out,
               Logger logger) {
  if (!base.scenario_dir.empty())
    throw StartupError("--seeds generates one street per seed: give no scenario_dir");
  if (base.encodings.size() > 1)
    throw StartupError(
        "--seeds aggregates one encoding per strategy and density: list at most "
        "one under encodings (the config lists " +
        std::to_string(base.encodings.size()) + ")");
  std::vector<eval::EvalResults> runs;
  for (const std::uint64_t seed : o.seeds) {
    EvalConfig config = base;
    config.scenario.seed = seed;
    const std::string seed_out = (fs::path(out) / ("seed-" + std::to_string(seed))).string();
    fs::create_directories(seed_out);
    const fs::path done = fs::path(seed_out) / "results.json";
    if (fs::is_regular_file(done)) {
      logger->info("seed {}: reusing {}", seed, done.string());
      eval::EvalResults earlier;
      earlier.summary = eval::read_summary(done.string());
      runs.push_back(std::move(earlier));
      continue;
    }
    logger->info("seed {}: {}", seed, seed_out);
    const std::string scenario = eval::prepare_scenario(config, seed_out, logger);
    runs.push_back(eval::run_eval(config, scenario, logger));
    eval::write_results(runs.back(), seed_out);
  }
  const auto points = eval::aggregate_seeds(runs);
  eval::write_seed_results(points, o.seeds, out);
  std::string problem;
  if (!eval::plot_results(out, o.python, problem, "plot_seeds.py"))
    logger->warn("no plot: {}", problem);
  print_seed_summary(points, o.seeds.size());
  std::printf(
      "\n%s/seeds.md, seeds.json, seeds.csv, seeds_fig6.png; each seed's results in seed-<n>/\n",
      out.c_str());
}

void run_eval_command(const EvalOptions& o) {
  EvalConfig config = load_eval_config(o.config);
  if (!o.scenario_dir.empty()) config.scenario_dir = o.scenario_dir;
  const std::string out = o.out.empty() ? default_out() : o.out;
  fs::create_directories(out);
  {
    std::ofstream effective(fs::path(out) / "eval.yaml");
    effective << to_yaml(config) << "\n";
  }
  Logger logger = make_logger("eval", "info");
  if (!o.seeds.empty()) return run_seeds(config, o, out, logger);
  const std::string scenario = eval::prepare_scenario(config, out, logger);
  const eval::EvalResults results = eval::run_eval(config, scenario, logger);
  eval::write_results(results, out);
  std::string problem;
  if (!eval::plot_results(out, o.python, problem)) logger->warn("no plots: {}", problem);
  print_summary(results);
  std::printf("\n%s/report.md, results.json, results.csv, fig6a_words.png, fig6b_places.png%s\n",
              out.c_str(), results.encodings.empty() ? "" : ", fig_encodings.png");
}

}  // namespace

void add_eval_commands(CLI::App& app) {
  auto options = std::make_shared<EvalOptions>();
  auto* eval = app.add_subcommand(
      "eval", "Fig. 6 of Alonso et al. 2019 on a generated scenario: words read, places, bytes");
  eval->add_option("config", options->config, "evaluation YAML (see configs/eval.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  eval->add_option("--out", options->out, "output folder (default runs/eval-<time>)");
  eval->add_option("--scenario-dir", options->scenario_dir,
                   "evaluate a scenario generated before instead of generating one")
      ->check(CLI::ExistingDirectory);
  eval->add_option("--python", options->python, "Python with matplotlib, for the plots");
  eval->add_option("--seeds", options->seeds,
                   "evaluate one generated street per seed and report means with 95 % intervals");
  eval->callback([options] { run_reporting([&] { run_eval_command(*options); }); });
}

}  // namespace keyfleet::commands
