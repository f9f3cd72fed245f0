// `keyfleet eval CONFIG [--out DIR]`: Fig. 6 of Alonso et al. (ICRA 2019) (words read and place
// recognition against the share of V-SLAM keyframes kept) on a generated scenario.
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/eval_runner.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

struct EvalOptions {
  std::string config;
  std::string out;
  std::string scenario_dir;
  std::string python = "/usr/bin/python3";
};

std::string default_out() {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
  return std::string("runs/eval-") + stamp;
}

void print_summary(const eval::EvalResults& r) {
  std::printf("\n%-9s %6s %5s %11s %11s %7s %7s %9s\n", "strategy", "kept", "kf", "words read",
              "words full", "top-1", "top-5", "MB sent");
  for (const auto& p : r.summary)
    std::printf("%-9s %5.0f%% %5zu %5zu/%-5zu %5zu/%-5zu %7.3f %7.3f %9.2f\n", p.strategy.c_str(),
                100 * p.density, p.keyframes, p.words_read, p.words_in_sequence, p.full_words,
                p.words_in_sequence, p.topk.top1_rate(), p.topk.top5_rate(), p.bytes / 1e6);
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
  const std::string scenario = eval::prepare_scenario(config, out, logger);
  const eval::EvalResults results = eval::run_eval(config, scenario, logger);
  eval::write_results(results, out);
  std::string problem;
  if (!eval::plot_results(out, o.python, problem)) logger->warn("no plots: {}", problem);
  print_summary(results);
  std::printf("\n%s/report.md, results.json, results.csv, fig6a_words.png, fig6b_places.png\n",
              out.c_str());
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
  eval->callback([options] { run_reporting([&] { run_eval_command(*options); }); });
}

}  // namespace keyfleet::commands
