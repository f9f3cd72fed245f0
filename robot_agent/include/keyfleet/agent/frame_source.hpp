#pragma once
#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

struct Frame {
  std::uint64_t index = 0;           // 0-based position in the stream
  std::int64_t capture_time_ns = 0;  // stream clock: index / fps for recorded sources
  cv::Mat image;                     // BGR, 8 bits per channel (reduced: see below)
  std::optional<Pose> pose;          // camera-to-world, when the source knows it
  // Where the source decoded less than the whole frame (selector.decode_reduce), `image` is the
  // reduced decode, `full_size` the frame's own size and `encoded` its compressed file, which
  // full_image() decodes again for what needs every pixel (the keyframe, the baseline's samples).
  // Empty where `image` is the whole frame.
  cv::Size full_size = {};
  std::shared_ptr<const std::vector<std::uint8_t>> encoded = nullptr;
};

// The frame's own size (what the keyframe is, and what text regions are given in).
cv::Size frame_size(const Frame& frame);
// The whole frame: `image` itself, or `encoded` decoded at full size; empty when that decode
// fails (the file's bytes are the ones the reduced image came from, so only a broken decoder
// fails here).
cv::Mat full_image(const Frame& frame);
// Reads an image file into frame.image: at 1/reduce (2, 4 or 8) where it is a JPEG libjpeg
// takes, its bytes kept in frame.encoded; whole otherwise (then `buffer` holds the file and is
// reused from call to call). False when the file cannot be read or decoded.
bool read_frame_image(const std::string& path, int reduce, std::vector<std::uint8_t>& buffer,
                      Frame& frame);

// Seam for where frames come from (camera, recording, simulator). next() returns
// nullopt at the end of the stream; a frame that cannot be read is logged and skipped.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual std::optional<Frame> next() = 0;
  virtual double fps() const = 0;
  virtual std::string describe() const = 0;
};

// Sorted image files (png, jpg, jpeg, bmp, tif, tiff, ppm, pgm) of one folder. JPEGs are decoded
// at 1/decode_reduce (selector.decode_reduce), the others whole.
std::unique_ptr<FrameSource> make_image_folder_source(const SourceConfig& config, Logger logger,
                                                      int decode_reduce = 1);
// Any video OpenCV's videoio can read; fps from the file when it has one.
std::unique_ptr<FrameSource> make_video_file_source(const SourceConfig& config, Logger logger);
// A camera flying along a procedurally drawn street with signs: deterministic from the seed.
std::unique_ptr<FrameSource> make_generated_source(const SourceConfig& config);

// Replays one drone of a generated scenario (config.path = scenario folder, config.drone =
// its robot id) with the scenario's timestamps and poses; JPEG frames at 1/decode_reduce.
std::unique_ptr<FrameSource> make_scenario_source(const SourceConfig& config, Logger logger,
                                                  int decode_reduce = 1);

// Picks by config.kind; throws StartupError with the path when the source cannot open.
// `decode_reduce` (selector.decode_reduce) applies to the sources that read JPEG files.
std::unique_ptr<FrameSource> make_frame_source(const SourceConfig& config, Logger logger,
                                               int decode_reduce = 1);

}  // namespace keyfleet::agent
