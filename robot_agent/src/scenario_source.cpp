// Replays a drone of a generated scenario: its frames, timestamps and true poses.
#include <algorithm>
#include <filesystem>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"
#include "keyfleet/common/scenario_truth.hpp"

namespace keyfleet::agent {
namespace {

namespace fs = std::filesystem;

class ScenarioSource final : public FrameSource {
 public:
  ScenarioSource(const SourceConfig& config, Logger logger, int decode_reduce)
      : config_(config), logger_(std::move(logger)), decode_reduce_(decode_reduce) {
    scenario::Scenario scenario;
    try {
      scenario = scenario::read_scenario(config.path);
    } catch (const std::exception& e) {
      throw StartupError(std::string("source.path: ") + e.what());
    }
    const auto drone = std::find_if(scenario.drones.begin(), scenario.drones.end(),
                                    [&](const auto& d) { return d.robot_id == config.drone; });
    if (drone == scenario.drones.end()) {
      std::string known;
      for (const auto& d : scenario.drones) known += (known.empty() ? "" : ", ") + d.robot_id;
      throw StartupError("source.drone: scenario " + config.path + " has no drone '" +
                         config.drone + "' (it has " + known + ")");
    }
    folder_ = fs::path(config.path) / drone->folder;
    fps_ = drone->fps;
    try {
      truth_ = scenario::read_frame_truth(folder_.string());
    } catch (const std::exception& e) {
      throw StartupError(std::string("source.path: ") + e.what());
    }
  }

  std::optional<Frame> next() override {
    while (position_ < truth_.size()) {
      if (config_.max_frames && position_ >= config_.max_frames) return std::nullopt;
      const auto& truth = truth_[position_++];
      Frame frame;
      if (!read_frame_image((folder_ / truth.image).string(), decode_reduce_, file_bytes_, frame)) {
        logger_->error("skipping unreadable scenario frame {}", (folder_ / truth.image).string());
        continue;
      }
      frame.index = truth.index;
      frame.capture_time_ns = truth.timestamp_ns;
      frame.pose = truth.camera_to_world;
      return frame;
    }
    return std::nullopt;
  }

  double fps() const override { return fps_; }
  std::string describe() const override {
    return "scenario " + config_.path + " drone " + config_.drone + " (" +
           std::to_string(truth_.size()) + " frames)";
  }

 private:
  SourceConfig config_;
  Logger logger_;
  int decode_reduce_ = 1;
  fs::path folder_;
  double fps_ = 30;
  std::vector<scenario::FrameTruth> truth_;
  std::size_t position_ = 0;
  std::vector<std::uint8_t> file_bytes_;  // the current frame's file, one buffer for all
};

}  // namespace

std::unique_ptr<FrameSource> make_scenario_source(const SourceConfig& config, Logger logger,
                                                  int decode_reduce) {
  return std::make_unique<ScenarioSource>(config, std::move(logger), decode_reduce);
}

}  // namespace keyfleet::agent
