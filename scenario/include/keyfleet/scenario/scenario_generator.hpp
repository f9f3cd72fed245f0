#pragma once
#include <string>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/scenario/plane_renderer.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/street_world.hpp"

namespace keyfleet::scenario {

struct GenerationSummary {
  Scenario scenario;
  std::uint64_t frames = 0;
  double seconds = 0;
  std::uint64_t bytes_on_disk = 0;
};

CameraModel camera_model(const ScenarioConfig& config);

// Words of `world` seen in a rendered view, with their visibility (plane_id buffer).
std::vector<WordInView> words_in_view(const StreetWorld& world, const PlaneRenderer& renderer,
                                      const CameraPose& pose, const cv::Mat& plane_id);

// Writes a whole scenario (see scenario_truth.hpp for the format) into `out_dir`, which
// must not hold another scenario. Deterministic: same config, same bytes. Drones are
// rendered in parallel, `threads` at a time (0 = one per core).
GenerationSummary generate_scenario(const ScenarioConfig& config, const std::string& out_dir,
                                    Logger logger, unsigned threads = 0);

// Writes `count` image + text-mask pairs (images/NNNNNN.jpg, masks/NNNNNN.png, 255 = text)
// from random viewpoints over streets built from `config`, for segmentation training.
GenerationSummary generate_training_set(const ScenarioConfig& config, const std::string& out_dir,
                                        std::uint64_t count, Logger logger);

}  // namespace keyfleet::scenario
