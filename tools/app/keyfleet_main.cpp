// keyfleet: the user's entry point. Subcommands: mission.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <vector>

#include "commands.hpp"

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/eval/selection_eval.hpp"
#include "keyfleet/mission/mission_config.hpp"
#include "keyfleet/mission/mission_runner.hpp"
#include "keyfleet/scenario/montage.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"

#include <opencv2/imgcodecs.hpp>

namespace {

using namespace keyfleet;

int run_mission(const std::string& config_path, int drones, const std::string& run_root) {
  MissionConfig config = load_mission_config(config_path);
  if (drones > 0) config.drones = drones;
  if (!run_root.empty()) config.run_root = run_root;
  Logger logger = make_logger("mission", "info");
  ShutdownSignal shutdown;
  mission::MissionBinaries binaries{mission::find_sibling_executable("robot_agent"),
                                    mission::find_sibling_executable("ground_station")};
  mission::MissionRunner runner(config, binaries, logger, std::cout);
  const mission::MissionResult result = runner.run(shutdown.stop);
  std::cout << "\n" << result.report_table;
  if (!result.scenario_dir.empty())
    commands::print_run_text_score(result.run_dir, result.scenario_dir);
  std::cout << "\nrun folder: " << result.run_dir;
  if (!result.report_html.empty())
    std::cout << "\n  report.html  the run to look at (opens from disk in a browser)";
  std::cout << "\n  station/station.sqlite  keyframes (SQLite)"
               "\n  station/mission_log.pb  mission log (protobuf, length-delimited)"
               "\n  station/report.{txt,json,csv}  bandwidth report"
               "\n  <robot>/agent.log, station/station.log  process logs\n";
  if (!result.ok) {
    std::cerr << "\nmission FAILED:\n";
    for (const auto& failure : result.failures) std::cerr << "  - " << failure << "\n";
    return 1;
  }
  std::cout << "mission OK\n";
  return 0;
}

void print_summary(const scenario::GenerationSummary& summary, const std::string& out) {
  std::printf("%llu frames in %.1f s (%.1f frames/s), %.1f MB on disk in %s\n",
              static_cast<unsigned long long>(summary.frames), summary.seconds,
              summary.seconds > 0 ? double(summary.frames) / summary.seconds : 0.0,
              double(summary.bytes_on_disk) / 1e6, out.c_str());
}

int run_scenario_generate(const std::string& config_path, const std::string& out,
                          unsigned threads) {
  const ScenarioConfig config = load_scenario_config(config_path);
  Logger logger = make_logger("scenario", "info");
  print_summary(scenario::generate_scenario(config, out, logger, threads), out);
  return 0;
}

int run_scenario_training(const std::string& config_path, const std::string& out,
                          std::uint64_t count, std::optional<std::uint64_t> seed) {
  ScenarioConfig config = load_scenario_config(config_path);
  if (seed) config.seed = *seed;
  Logger logger = make_logger("training", "info");
  print_summary(scenario::generate_training_set(config, out, count, logger), out);
  return 0;
}

int run_scenario_montage(const std::string& dir, const std::string& out,
                         const scenario::MontageOptions& options) {
  const cv::Mat montage = scenario::scenario_montage(dir, options);
  if (!cv::imwrite(out, montage)) throw std::runtime_error("cannot write " + out);
  std::printf("%dx%d montage written to %s\n", montage.cols, montage.rows, out.c_str());
  return 0;
}

int run_selection_eval(const std::string& scenario_dir, const std::vector<std::string>& drones,
                       const std::string& agent_config, const std::string& model) {
  AgentConfig agent = agent_config.empty() ? AgentConfig{} : load_agent_config(agent_config);
  if (!model.empty()) agent.selector.semantic.model = model;
  std::vector<SelectorConfig::Strategy> strategies = {SelectorConfig::Strategy::kVslam,
                                                      SelectorConfig::Strategy::kQuality};
  if (!agent.selector.semantic.model.empty()) {
    strategies.push_back(SelectorConfig::Strategy::kSemantic);
    strategies.push_back(SelectorConfig::Strategy::kFull);
  } else {
    std::printf("(no text model given: semantic and full skipped; pass --model)\n");
  }
  for (const auto& drone : drones) {
    const auto e = eval::evaluate_selection(scenario_dir, drone, agent.selector, strategies);
    std::printf(
        "\n%s: %zu frames, %zu distinct words fully visible in the sequence, trigger "
        "%.2f ms/frame\n",
        e.drone.c_str(), e.frames, e.words_in_sequence, e.trigger_ms_per_frame);
    std::printf("%-9s %6s %6s %12s %11s %10s %10s %10s\n", "strategy", "vslam", "sent",
                "words(full)", "word views", "blur px", "sharpness", "ms/frame");
    for (const auto& r : e.strategies)
      std::printf("%-9s %6zu %6zu %12zu %11zu %10.2f %10.3f %10.2f\n", r.strategy.c_str(),
                  r.vslam_keyframes, r.keyframes, r.distinct_full_words, r.full_word_views,
                  r.mean_blur_px, r.mean_sharpness, r.cpu_ms_per_frame);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  keyfleet::limit_openmp_to_one_thread(argv);
  keyfleet::block_termination_signals();
  keyfleet::keep_created_files_private();
  keyfleet::keep_image_buffers_in_heap();
  CLI::App app{"keyfleet: keyframe sharing for robot fleets over weak links"};
  app.require_subcommand(1);

  auto* mission =
      app.add_subcommand("mission", "run a simulated multi-drone mission on this machine");
  std::string config_path;
  int drones = 0;
  std::string run_root;
  mission->add_option("config", config_path, "mission YAML (see configs/demo_mission.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  mission->add_option("--drones", drones, "override the number of drones")
      ->check(CLI::Range(1, 64));
  mission->add_option("--run-root", run_root, "override where run folders are created");

  auto* scenario = app.add_subcommand("scenario", "generated multi-drone street scenarios");
  scenario->require_subcommand(1);
  auto* generate = scenario->add_subcommand("generate", "write a scenario: frames + ground truth");
  std::string scenario_config, out;
  unsigned threads = 0;
  generate->add_option("config", scenario_config, "scenario YAML (see configs/scenario_small.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  generate->add_option("--out", out, "output folder (must not hold a scenario)")->required();
  generate->add_option("--threads", threads, "drones rendered at once (0 = one per core)");
  auto* training =
      scenario->add_subcommand("training", "write image + text-mask pairs for MiniNet");
  std::uint64_t count = 1000;
  training->add_option("config", scenario_config, "scenario YAML")
      ->required()
      ->check(CLI::ExistingFile);
  training->add_option("--out", out, "output folder")->required();
  training->add_option("--count", count, "number of pairs")->check(CLI::Range(1, 10000000));
  std::optional<std::uint64_t> training_seed;
  training->add_option("--seed", training_seed, "other streets than the config's seed gives");

  auto* montage = scenario->add_subcommand("montage", "a picture of frames from a scenario");
  std::string scenario_dir;
  scenario::MontageOptions montage_options;
  montage->add_option("dir", scenario_dir, "scenario folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  montage->add_option("--out", out, "image file to write (.jpg/.png)")->required();
  montage->add_option("--drones", montage_options.drones, "drones to show (default: all)");
  montage->add_option("--frames", montage_options.frames, "frame indices (default: five)");
  montage->add_option("--tile-width", montage_options.tile_width, "width of each frame")
      ->check(CLI::Range(32, 4096));
  montage->add_flag("--words", montage_options.draw_words,
                    "outline ground-truth words (green full, yellow cut, red occluded)");

  auto* selection = app.add_subcommand("selection", "the agent's keyframe selection, offline");
  selection->require_subcommand(1);
  auto* evaluate = selection->add_subcommand(
      "eval", "strategies against a scenario's ground truth (same V-SLAM keyframes for all)");
  std::vector<std::string> eval_drones = {"drone_0"};
  std::string eval_agent_config, eval_model;
  evaluate->add_option("scenario", scenario_dir, "scenario folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  evaluate->add_option("--drones", eval_drones, "drones to evaluate");
  evaluate->add_option("--config", eval_agent_config, "agent YAML whose selector settings to use")
      ->check(CLI::ExistingFile);
  evaluate->add_option("--model", eval_model, "ONNX text segmenter for semantic and full")
      ->check(CLI::ExistingFile);

  keyfleet::commands::add_trigger_commands(*selection);

  keyfleet::commands::add_segmenter_commands(app);
  keyfleet::commands::add_security_commands(app);
  keyfleet::commands::add_bench_commands(app);
  keyfleet::commands::add_station_commands(app);
  keyfleet::commands::add_ocr_commands(app);
  keyfleet::commands::add_vocabulary_commands(app);
  keyfleet::commands::add_experiment_commands(app);
  keyfleet::commands::add_eval_commands(app);
  keyfleet::commands::add_places_commands(app);
  keyfleet::commands::add_config_commands(app);

  CLI11_PARSE(app, argc, argv);
  try {
    if (*mission) return run_mission(config_path, drones, run_root);
    if (*generate) return run_scenario_generate(scenario_config, out, threads);
    if (*training) return run_scenario_training(scenario_config, out, count, training_seed);
    if (*montage) return run_scenario_montage(scenario_dir, out, montage_options);
    if (*evaluate)
      return run_selection_eval(scenario_dir, eval_drones, eval_agent_config, eval_model);
  } catch (const std::exception& e) {
    std::cerr << "keyfleet: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
