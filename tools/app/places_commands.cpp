// `keyfleet places eval CONFIG --seeds N... [--corridor DIR]`: place retrieval by the ORB bag of
// words, the CNN descriptor and their fusion, on generated two-day streets (one per seed, the
// street of an evaluation YAML) and the real vpr_corridor; recall@1/@5, verified accuracy,
// queries as captured, blurred and darkened; means with 95 % intervals over the seeds.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/file_output.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/eval_runner.hpp"
#include "keyfleet/eval/place_eval.hpp"
#include "keyfleet/eval/seed_aggregate.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/place_describer.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

struct PlacesEvalOptions {
  std::string config;
  std::string out = "runs/places-eval";
  std::vector<std::uint64_t> seeds;
  std::string corridor;
  std::vector<std::string> modes = {"bow", "cnn", "fusion"};
  std::string descriptor;
  int database_every = 5;
  int min_inliers = 0;  // 0 = the station's
};

// A rate's mean and, over several datasets, its interval clipped to the possible [0, 100].
std::string percent(const eval::Interval& i) {
  char text[64];
  if (i.n > 1)
    std::snprintf(text, sizeof text, "%.1f [%.1f, %.1f]", 100 * i.mean, 100 * std::max(0.0, i.low),
                  100 * std::min(1.0, i.high));
  else
    std::snprintf(text, sizeof text, "%.1f", 100 * i.mean);
  return text;
}

// One markdown table: per condition and mode, the mean (and interval) over the datasets given.
std::string table(const std::vector<eval::RetrievalScore>& rows) {
  std::map<std::pair<std::string, std::string>, std::vector<const eval::RetrievalScore*>> groups;
  std::vector<std::pair<std::string, std::string>> order;
  for (const auto& r : rows) {
    auto& g = groups[{r.condition, r.mode}];
    if (g.empty()) order.emplace_back(r.condition, r.mode);
    g.push_back(&r);
  }
  std::ostringstream md;
  md << "| queries | retrieval | recall@1 % | recall@5 % | verified top-1 % | precision of "
        "accepted % | ms per query |\n|---|---|---|---|---|---|---|\n";
  for (const auto& key : order) {
    std::vector<double> r1, r5, verified, precision, ms;
    std::size_t queries = 0;
    for (const auto* r : groups[key]) {
      r1.push_back(r->recall1());
      r5.push_back(r->recall5());
      verified.push_back(r->verified());
      precision.push_back(r->precision());
      ms.push_back(r->recognise_ms);
      queries += r->queries;
    }
    char cost[32];
    std::snprintf(cost, sizeof cost, "%.1f", eval::median(ms));
    md << "| " << key.first << " (" << queries << ") | " << key.second << " | "
       << percent(eval::mean_interval(r1)) << " | " << percent(eval::mean_interval(r5)) << " | "
       << percent(eval::mean_interval(verified)) << " | " << percent(eval::mean_interval(precision))
       << " | " << cost << " |\n";
  }
  return md.str();
}

nlohmann::json to_json(const std::vector<eval::RetrievalScore>& rows) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& r : rows)
    out.push_back({{"dataset", r.dataset},
                   {"condition", r.condition},
                   {"mode", r.mode},
                   {"queries", r.queries},
                   {"top1", r.top1},
                   {"top5", r.top5},
                   {"accepted", r.accepted},
                   {"accepted_right", r.accepted_right},
                   {"recognise_ms", r.recognise_ms}});
  return out;
}

void run_places_eval(const PlacesEvalOptions& o) {
  Logger logger = make_logger("places", "info");
  cv::setNumThreads(1);  // the descriptor's and ORB's cost on one thread, as the station runs them
  const EvalConfig base = load_eval_config(o.config);
  eval::PlaceEvalSettings settings;
  settings.places.vocabulary = base.vocabulary;
  settings.places.orb_features = base.orb_features;
  if (!o.descriptor.empty()) settings.places.descriptor = o.descriptor;
  settings.query_every = base.query_every;
  settings.tolerance_m = base.place_tolerance_m;
  settings.database_every = o.database_every;
  if (o.min_inliers > 0) settings.places.min_inliers = o.min_inliers;
  settings.modes.clear();
  for (const auto& name : o.modes) {
    const auto mode = place_retrieval(name);
    if (!mode)
      throw StartupError("--modes " + name + ": must be one of " + place_retrieval_choices());
    settings.modes.push_back(*mode);
  }
  fs::create_directories(o.out);

  std::vector<eval::RetrievalScore> streets, corridor;
  eval::PlaceEvalCost cost;
  for (const std::uint64_t seed : o.seeds) {
    EvalConfig config = base;
    config.scenario.seed = seed;
    const std::string seed_out = (fs::path(o.out) / ("seed-" + std::to_string(seed))).string();
    fs::create_directories(seed_out);
    const std::string scenario = eval::prepare_scenario(config, seed_out, logger);
    const auto rows = eval::evaluate_places_on_scenario(
        scenario, config.scenario.name + "-" + std::to_string(seed), settings, cost, logger);
    streets.insert(streets.end(), rows.begin(), rows.end());
  }
  if (!o.corridor.empty())
    corridor = eval::evaluate_places_on_corridor(o.corridor, settings, cost, logger);
  const int dimensions =
      vision::read_place_describer_info(
          vision::locate_model(settings.places.descriptor, "place descriptor model"))
          .dimensions;
  const double query_10k = eval::descriptor_query_ms(10000, dimensions);

  std::ostringstream md;
  if (!streets.empty()) {
    md << "**Generated two-day streets** (`" << fs::path(o.config).filename().string()
       << "`, seeds";
    for (auto s : o.seeds) md << " " << s;
    md << "; mean [95 % Student t interval, clipped to 0-100] over the seeds): every "
       << settings.database_every << "th frame of the first day's drones stored, every "
       << settings.query_every << "th frame of the other day's drones a query, right within "
       << settings.tolerance_m << " m of street.\n\n"
       << table(streets) << "\n";
  }
  if (!corridor.empty())
    md << "**vpr_corridor** (real, 111 reference and 111 query frames, 160x120; verified with more "
          "than "
       << settings.places.min_inliers << " inliers):\n\n"
       << table(corridor) << "\n";
  char costs[256];
  std::snprintf(costs, sizeof costs,
                "Per view on one thread (medians of %zu): descriptor %.2f ms, ORB %.2f ms; exact "
                "descriptor query over 10000 stored keyframes %.3f ms.\n",
                cost.describe_ms.size(), eval::median(cost.describe_ms), eval::median(cost.orb_ms),
                query_10k);
  md << costs;
  write_file(fs::path(o.out) / "places.md", md.str());
  nlohmann::json j = {{"streets", to_json(streets)},
                      {"corridor", to_json(corridor)},
                      {"describe_ms", eval::median(cost.describe_ms)},
                      {"orb_ms", eval::median(cost.orb_ms)},
                      {"query_ms_10k", query_10k},
                      {"descriptor", settings.places.descriptor},
                      {"seeds", o.seeds}};
  write_file(fs::path(o.out) / "places.json", j.dump(1) + "\n");
  std::printf("%s\n%s/places.md, places.json\n", md.str().c_str(), o.out.c_str());
}

}  // namespace

void add_places_commands(CLI::App& app) {
  auto* places = app.add_subcommand("places", "place recognition, offline");
  places->require_subcommand(1);
  auto options = std::make_shared<PlacesEvalOptions>();
  auto* evaluate = places->add_subcommand(
      "eval", "retrieval by bag of words, CNN descriptor and fusion: recall@1/@5, verified");
  evaluate->add_option("config", options->config, "evaluation YAML whose street is generated")
      ->required()
      ->check(CLI::ExistingFile);
  evaluate->add_option("--seeds", options->seeds, "one generated street per seed");
  evaluate->add_option("--corridor", options->corridor, "the vpr_corridor folder as well")
      ->check(CLI::ExistingDirectory);
  evaluate->add_option("--modes", options->modes, "retrieval modes (bow cnn fusion)");
  evaluate->add_option("--descriptor", options->descriptor,
                       "descriptor model (default: the station's, placenet.onnx)");
  evaluate
      ->add_option("--database-every", options->database_every,
                   "every n-th frame of the first day is a stored keyframe")
      ->check(CLI::Range(1, 1000));
  evaluate
      ->add_option("--min-inliers", options->min_inliers,
                   "verification threshold (default: the station's, for 640x480 keyframes)")
      ->check(CLI::Range(4, 100000));
  evaluate->add_option("--out", options->out, "output folder (default runs/places-eval)");
  evaluate->callback([options] { run_reporting([&] { run_places_eval(*options); }); });
}

}  // namespace keyfleet::commands
