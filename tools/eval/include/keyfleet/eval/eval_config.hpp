#pragma once
// `keyfleet eval`, loaded from YAML by eval_config.cpp.
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"

namespace keyfleet {

// One way of sending the selected keyframes (issue 30: information per byte). The frame is
// encoded as the agent's send ladder would (agent/level_encoding.hpp: JPEG at jpeg_quality,
// resized to `scale`, or with text_aware the frame's size kept, every pixel of its text regions
// kept and only the background coarsened), decoded, and read and described from the decoded
// image, at its own size.
struct EvalEncoding {
  std::string name;       // [A-Za-z0-9_.-]{1,32}, unique in the list
  int jpeg_quality = 85;  // 1..100
  double scale = 1.0;     // of the frame's width and height, in (0, 1]
  bool text_aware = false;
};

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
  // Encodings compared (each strategy and density evaluated once per encoding; the first is
  // the reference the others are measured against). Empty (the default): today's Fig. 6, the
  // words read and the places described from the raw camera frames, bytes counted as the
  // frame's JPEG at codec.jpeg_quality.
  std::vector<EvalEncoding> encodings;
  int text_margin_px = 4;  // text-aware encodings: pixels kept around each text region
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
