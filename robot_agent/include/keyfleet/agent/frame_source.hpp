#pragma once
#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

struct Frame {
  std::uint64_t index = 0;           // 0-based position in the stream
  std::int64_t capture_time_ns = 0;  // stream clock: index / fps for recorded sources
  cv::Mat image;                     // BGR, 8 bits per channel
  std::optional<Pose> pose;          // camera-to-world, when the source knows it
};

// Seam for where frames come from (camera, recording, simulator). next() returns
// nullopt at the end of the stream; a frame that cannot be read is logged and skipped.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual std::optional<Frame> next() = 0;
  virtual double fps() const = 0;
  virtual std::string describe() const = 0;
};

// Sorted image files (png, jpg, jpeg, bmp, tif, tiff, ppm, pgm) of one folder.
std::unique_ptr<FrameSource> make_image_folder_source(const SourceConfig& config, Logger logger);
// Any video OpenCV's videoio can read; fps from the file when it has one.
std::unique_ptr<FrameSource> make_video_file_source(const SourceConfig& config, Logger logger);
// A camera flying along a procedurally drawn street with signs: deterministic from the seed.
std::unique_ptr<FrameSource> make_generated_source(const SourceConfig& config);

// Replays one drone of a generated scenario (config.path = scenario folder, config.drone =
// its robot id) with the scenario's timestamps and poses.
std::unique_ptr<FrameSource> make_scenario_source(const SourceConfig& config, Logger logger);

// Picks by config.kind; throws StartupError with the path when the source cannot open.
std::unique_ptr<FrameSource> make_frame_source(const SourceConfig& config, Logger logger);

}  // namespace keyfleet::agent
