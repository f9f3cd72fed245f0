#pragma once
// `keyfleet eval`, loaded from YAML by eval_config.cpp.
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"

namespace keyfleet {

// `keyfleet eval` (configs/eval.yaml): the first seed's Fig. 6 on a generated scenario.
struct EvalConfig {
  ScenarioConfig scenario;   // generated into <out>/scenario unless scenario_dir is set
  std::string scenario_dir;  // a scenario generated before (relative to the file)
  std::vector<std::string> strategies = {"vslam", "quality", "semantic", "full"};
  // Fractions of the V-SLAM keyframes kept, spread evenly (the same for every strategy).
  std::vector<double> densities = {1.0, 0.75, 0.5, 0.35, 0.2, 0.1};
  std::vector<std::string> drones;  // empty = every drone of the scenario
  SelectorConfig selector;          // the agent's selection; strategy and density set per point
  CodecConfig codec;                // the agent's JPEG quality (bytes sent)
  std::string vocabulary = "orb_vocabulary.bin";  // place recognition (a bare name: shipped)
  int orb_features = 1000;
  // Fig. 6b's retrieval modes (as station.yaml's analysis.places.retrieval): each is scored;
  // the summary, the plots and the claims use the first.
  std::vector<std::string> place_retrievals = {"bow", "cnn", "fusion"};
  std::string place_descriptor = "placenet.onnx";  // the model cnn and fusion use
  int query_every = 10;            // place queries: every n-th frame of the query drone
  double place_tolerance_m = 5.0;  // a retrieved keyframe is right within this street distance
  int ocr_threads = 2;             // text readers at once (one Tesseract each)
  // The text reader, as the station configures it (station.yaml analysis.text; `enabled` is
  // ignored: the evaluation always reads).
  TextReadingConfig text;
};

// Paths are relative to the file, as in a scenario file. Throws ConfigError.
EvalConfig load_eval_config(const std::string& path);
EvalConfig parse_eval_config(const std::string& text, const std::string& origin);
std::string to_yaml(const EvalConfig& config);

}  // namespace keyfleet
