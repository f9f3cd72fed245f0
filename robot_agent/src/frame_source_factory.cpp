#include "keyfleet/agent/frame_source.hpp"

#include "keyfleet/common/error.hpp"

namespace keyfleet::agent {

std::unique_ptr<FrameSource> make_frame_source(const SourceConfig& config, Logger logger,
                                               int decode_reduce) {
  switch (config.kind) {
    case SourceConfig::Kind::kImageFolder:
      return make_image_folder_source(config, logger, decode_reduce);
    case SourceConfig::Kind::kVideoFile: return make_video_file_source(config, logger);
    case SourceConfig::Kind::kGenerated: return make_generated_source(config);
    case SourceConfig::Kind::kScenario: return make_scenario_source(config, logger, decode_reduce);
  }
  throw StartupError("source.kind: unsupported");
}

}  // namespace keyfleet::agent
