#pragma once
// `keyfleet eval`: Fig. 6 of Alonso et al. (ICRA 2019) on a generated two-day multi-drone scenario.
// For each strategy and kept fraction of the V-SLAM keyframes: (a) words the station's text reader
// reads in the selected keyframes, against the words fully visible in the sequence, (b) place
// recognition top-1/top-5 from one drone's frames against another day's drone's selected keyframes,
// (c) bytes sent.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/metrics.hpp"

namespace keyfleet::eval {

// One drone, strategy and density. Word counts are distinct signs.
struct WordScore {
  std::string drone, strategy;
  double density = 1;
  std::size_t vslam_keyframes = 0;    // all of the drone's V-SLAM keyframes
  std::size_t keyframes = 0;          // sent (the same for every strategy at one density)
  std::size_t words_in_sequence = 0;  // legible and fully visible in some frame
  std::size_t full_words = 0;         // of those, fully visible in a selected frame
  std::size_t words_read = 0;         // of those, read by the text reader in a selected frame
  std::uint64_t bytes = 0;            // JPEG at the agent's quality
};

// Queries from one drone's frames against another drone's selected keyframes.
struct PlaceScore {
  std::string query_drone, database_drone, strategy;
  std::string retrieval = "bow";  // bow, cnn or fusion
  double density = 1;
  std::size_t database_keyframes = 0;
  std::size_t unanswerable = 0;  // queries no frame of the database drone is near: left out
  TopK topk;
};

// A strategy at one density, over every drone (word counts and bytes summed; recalls are
// the mean over drones, as the paper averages its sequences) and every place pair.
struct PointSummary {
  std::string strategy;
  double density = 1;
  std::size_t keyframes = 0, vslam_keyframes = 0;
  std::size_t words_in_sequence = 0, full_words = 0, words_read = 0;
  double word_recall = 0;       // words read / words in the sequence
  double full_word_recall = 0;  // words fully visible in a selected frame / words in sequence
  std::uint64_t bytes = 0;
  TopK topk;
};

struct EvalCost {
  std::size_t frames = 0;              // decoded frames, all drones
  double trigger_ms_per_frame = 0;     // the V-SLAM trigger, run once per drone (CPU)
  std::size_t selection_runs = 0;      // strategy x density x drone
  double selection_cpu_ms = 0;         // quality, sharpness, windows: recomputed per run
  std::size_t segmenter_requests = 0;  // frames the selections asked MiniNet about
  std::size_t segmenter_frames = 0;    // frames it actually ran on (cached per frame)
  double segmenter_cpu_ms = 0;
  std::size_t ocr_frames = 0;  // distinct selected frames, each read once
  double ocr_wall_s = 0;
  double ocr_median_ms = 0;    // per frame, one reader
  std::size_t orb_frames = 0;  // queries and distinct selected frames
  double orb_ms = 0;
  double wall_s = 0;
};

struct EvalResults {
  std::string scenario_dir, scenario_name;
  std::uint64_t scenario_seed = 0;
  std::vector<std::string> drones;  // "drone_0 (day 0, 600 frames)"
  std::vector<std::string> strategies;
  std::vector<double> densities;
  std::string text_reader;
  std::string vocabulary;
  double place_tolerance_m = 0;
  int query_every = 0;
  int jpeg_quality = 0;
  std::vector<WordScore> words;
  std::vector<PlaceScore> places;
  std::vector<std::string> place_retrievals;  // the first is the summary's
  std::vector<PointSummary> summary;
  // The summary's place figures with each retrieval mode (words and bytes as in summary).
  std::map<std::string, std::vector<PointSummary>> summary_by_retrieval;
  EvalCost cost;
};

// The scenario to evaluate: config.scenario_dir when set, else <out_dir>/scenario, generated
// from config.scenario unless a scenario is already there. Throws StartupError.
std::string prepare_scenario(const EvalConfig& config, const std::string& out_dir, Logger logger);

// Runs the whole evaluation on a scenario. Throws StartupError on a missing model,
// vocabulary, drone or frame.
EvalResults run_eval(const EvalConfig& config, const std::string& scenario_dir, Logger logger);

// The summary's point for a strategy and density; nullptr when it has none.
const PointSummary* find_point(const std::vector<PointSummary>& summary,
                               const std::string& strategy, double density);

// Sums and means per (strategy, density), in the order of `strategies` then `densities`.
std::vector<PointSummary> summarise(const std::vector<WordScore>& words,
                                    const std::vector<PlaceScore>& places,
                                    const std::vector<std::string>& strategies,
                                    const std::vector<double>& densities);

// results.json, results.csv and report.md in out_dir (the plots are plot_eval.py's).
void write_results(const EvalResults& results, const std::string& out_dir);

// The per-(strategy, density) summary of a results.json written by write_results (top-k counts
// recovered from the rates and query counts). Throws StartupError naming the file.
std::vector<PointSummary> read_summary(const std::string& results_json);

// Draws fig6a_words.png and fig6b_places.png from out_dir/results.json with
// tools/report/plot_eval.py (installed beside the binaries, else the source copy) and
// `python` (Debian's matplotlib). A missing script or library is not fatal: returns false
// and says why in `problem`.
// script_name: plot_eval.py (one run: fig6a_words.png, fig6b_places.png) or plot_seeds.py
// (--seeds: seeds_fig6.png).
bool plot_results(const std::string& out_dir, const std::string& python, std::string& problem,
                  const std::string& script_name = "plot_eval.py");

}  // namespace keyfleet::eval
