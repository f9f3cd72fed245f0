// `keyfleet selection triggers`: two V-SLAM triggers on the same frames (scenario drones,
// videos, image folders): keyframe counts and rates, how many fall within +-2 / +-5 frames of
// the other's, and the CPU each costs per frame.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/eval/selection_eval.hpp"
#include "keyfleet/eval/trigger_comparison.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

struct TriggerOptions {
  std::string scenario;
  std::vector<std::string> drones;
  std::vector<std::string> videos;
  std::vector<std::string> folders;
  std::string agent_config;
  std::string reference = "orbslam";
  std::string candidate = "klt";
  double folder_fps = 30;
};

TriggerConfig::Kind kind_of(const std::string& name) {
  if (const auto kind = trigger_kind(name)) return *kind;
  throw StartupError("unknown trigger '" + name + "' (one of " + trigger_kind_choices() + ")");
}

std::vector<agent::Frame> read_all(SourceConfig source, SourceConfig::Kind kind,
                                   const std::string& path, double* fps) {
  source.kind = kind;
  source.path = path;
  source.realtime = false;
  source.max_frames = 0;
  auto frames = agent::make_frame_source(source, make_logger("source", "warn"));
  *fps = frames->fps();
  std::vector<agent::Frame> out;
  while (auto frame = frames->next()) out.push_back(std::move(*frame));
  return out;
}

void run_trigger_comparison(const TriggerOptions& o) {
  const AgentConfig agent =
      o.agent_config.empty() ? AgentConfig{} : load_agent_config(o.agent_config);
  TriggerConfig reference = agent.selector.trigger, candidate = agent.selector.trigger;
  reference.kind = kind_of(o.reference);
  candidate.kind = kind_of(o.candidate);
  std::vector<eval::TriggerComparison> comparisons;
  auto compare = [&](const std::string& name, const std::vector<agent::Frame>& frames, double fps) {
    comparisons.push_back(eval::compare_triggers(name, frames, fps, reference, candidate));
    std::fprintf(stderr, "%s: %zu frames compared\n", name.c_str(), frames.size());
  };
  if (!o.scenario.empty()) {
    for (const auto& drone : o.drones) {
      const auto loaded = eval::load_drone_frames(o.scenario, drone, agent.selector.decode_reduce);
      compare(drone, loaded.for_selection(), loaded.info.fps);
    }
  }
  double fps = 30;
  SourceConfig source = agent.source;
  source.fps = o.folder_fps;
  for (const auto& video : o.videos) {
    const auto frames = read_all(source, SourceConfig::Kind::kVideoFile, video, &fps);
    compare(fs::path(video).filename().string(), frames, fps);
  }
  for (const auto& folder : o.folders) {
    const auto frames = read_all(source, SourceConfig::Kind::kImageFolder, folder, &fps);
    compare(fs::path(folder).lexically_normal().parent_path().filename().string() + "/" +
                fs::path(folder).lexically_normal().filename().string(),
            frames, fps);
  }
  if (comparisons.empty())
    throw StartupError("nothing to compare: give a scenario, --video or --folder");
  std::printf("%s", eval::format_comparisons(comparisons, o.reference, o.candidate).c_str());
}

}  // namespace

void add_trigger_commands(CLI::App& selection) {
  auto o = std::make_shared<TriggerOptions>();
  auto* cmd = selection.add_subcommand(
      "triggers", "two V-SLAM triggers on the same frames: keyframe positions, rates, CPU");
  cmd->add_option("--scenario", o->scenario, "scenario folder")->check(CLI::ExistingDirectory);
  cmd->add_option("--drones", o->drones, "the scenario's drones to compare")->expected(1, -1);
  cmd->add_option("--video", o->videos, "video files")->check(CLI::ExistingFile);
  cmd->add_option("--folder", o->folders, "image folders (frames in file-name order)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--folder-fps", o->folder_fps, "frame rate of the image folders")
      ->check(CLI::Range(1.0, 1000.0));
  cmd->add_option("--config", o->agent_config, "agent YAML whose trigger settings to use")
      ->check(CLI::ExistingFile);
  cmd->add_option("--reference", o->reference,
                  "reference trigger (" + trigger_kind_choices() + ")");
  cmd->add_option("--candidate", o->candidate, "candidate trigger");
  cmd->callback([o] { run_reporting([&] { run_trigger_comparison(*o); }); });
}

}  // namespace keyfleet::commands
