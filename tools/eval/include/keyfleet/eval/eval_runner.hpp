#pragma once
// `keyfleet eval`: Fig. 6 of Alonso et al. (ICRA 2019) on a generated two-day multi-drone scenario.
// For each strategy and kept fraction of the V-SLAM keyframes: (a) words the station's text reader
// reads in the selected keyframes, against the words fully visible in the sequence, (b) place
// recognition top-1/top-5 from one drone's frames against another day's drone's selected keyframes,
// (c) bytes sent. With encodings (EvalConfig::encodings), all of it once per encoding: the
// keyframes encoded as the agent's send ladder would, decoded, then read and described.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/eval/metrics.hpp"

namespace keyfleet::eval {

// One drone, strategy, density and encoding. Word counts are distinct signs.
struct WordScore {
  std::string drone, strategy;
  double density = 1;
  std::size_t vslam_keyframes = 0;    // all of the drone's V-SLAM keyframes
  std::size_t keyframes = 0;          // sent (the same for every strategy at one density)
  std::size_t words_in_sequence = 0;  // legible and fully visible in some frame
  std::size_t full_words = 0;         // of those, fully visible in a selected frame
  std::size_t words_read = 0;         // of those, read by the text reader in a selected frame
  std::uint64_t bytes = 0;            // JPEG at the agent's quality, or at the encoding's
  std::string encoding;  // the EvalEncoding's name; "" for the raw frames (no encodings listed)
};

// Queries from one drone's frames against another drone's selected keyframes.
struct PlaceScore {
  std::string query_drone, database_drone, strategy;
  std::string retrieval = "bow";  // bow, cnn or fusion
  double density = 1;
  std::size_t database_keyframes = 0;
  std::size_t unanswerable = 0;  // queries no frame of the database drone is near: left out
  TopK topk;
  std::string encoding;  // of the database keyframes ("" raw); the queries are camera frames
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
  std::string encoding;  // "" for the raw frames
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
  std::size_t orb_frames = 0;  // queries and distinct selected frames (each encoding's)
  double orb_ms = 0;
  std::size_t encoded_frames = 0;  // distinct selected frames encoded and decoded, all encodings
  double encode_ms = 0;
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
  // The encodings compared, in the config's order (the first is the reference); empty when
  // the raw frames were evaluated.
  std::vector<EvalEncoding> encodings;
  EvalCost cost;
};

// One encoding at one strategy and density, beside the reference encoding (the first) at the
// same strategy and density: what issue 30 asks of each encoding.
struct EncodingPoint {
  std::string encoding, strategy;
  double density = 1;
  std::size_t keyframes = 0;
  double kb_per_keyframe = 0;  // mean bytes of a keyframe sent / 1000
  std::size_t words_read = 0, words_in_sequence = 0;
  double word_recall = 0;
  double words_vs_reference = 0;       // words read / the reference's (0 when it read none)
  std::map<std::string, double> top1;  // per retrieval mode
  std::map<std::string, double> top1_vs_reference;  // minus the reference's, per mode
};

// Every (encoding, strategy, density) of the results' summaries, in the summaries' order;
// empty when the results hold no encodings.
std::vector<EncodingPoint> compare_encodings(const EvalResults& results);

// The scenario to evaluate: config.scenario_dir when set, else <out_dir>/scenario, generated
// from config.scenario unless a scenario is already there. Throws StartupError.
std::string prepare_scenario(const EvalConfig& config, const std::string& out_dir, Logger logger);

// Runs the whole evaluation on a scenario. Throws StartupError on a missing model,
// vocabulary, drone or frame.
EvalResults run_eval(const EvalConfig& config, const std::string& scenario_dir, Logger logger);

// The summary's point for a strategy and density (the first encoding's when it holds several);
// nullptr when it has none.
const PointSummary* find_point(const std::vector<PointSummary>& summary,
                               const std::string& strategy, double density);
// The same for one encoding.
const PointSummary* find_point(const std::vector<PointSummary>& summary,
                               const std::string& strategy, double density,
                               const std::string& encoding);

// Sums and means per (encoding, strategy, density), in the order of `encodings`, then
// `strategies`, then `densities` ("" names the raw frames' rows).
std::vector<PointSummary> summarise(const std::vector<WordScore>& words,
                                    const std::vector<PlaceScore>& places,
                                    const std::vector<std::string>& strategies,
                                    const std::vector<double>& densities,
                                    const std::vector<std::string>& encodings = {""});

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
