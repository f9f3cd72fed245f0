#pragma once
// OpenCV's image files and video files (its imgcodecs and videoio libraries) behind two plugins,
// each loaded the first time something needs it. Debian's two libraries bring about 220 more
// shared libraries (FFmpeg, GStreamer, GDAL, GDCM, ...) into any process that links them, whose
// loading was most of the robot agent's start (docs/results/2026-11-29-agent-start.md), where an
// agent reading JPEG frames needs neither: JPEGs go through libjpeg (jpeg_turbo.hpp).
// libkeyfleet_opencv_images.so links imgcodecs, libkeyfleet_opencv_video.so videoio.
#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace keyfleet {

class ImageFiles {
 public:
  virtual ~ImageFiles() = default;
  // cv::imdecode(bytes, flags) (flags: cv::ImreadModes); empty where OpenCV cannot decode them.
  // May throw cv::Exception as cv::imdecode does.
  virtual cv::Mat decode(const std::vector<std::uint8_t>& bytes, int flags) const = 0;
  // cv::imencode(extension, image, params); false where OpenCV cannot encode it.
  virtual bool encode(const std::string& extension, const cv::Mat& image,
                      const std::vector<int>& params, std::vector<std::uint8_t>& out) const = 0;
};

// A video file's frames in order (cv::VideoCapture).
class VideoReader {
 public:
  virtual ~VideoReader() = default;
  // The next frame (8-bit BGR); false at the end or where a frame cannot be decoded.
  virtual bool read(cv::Mat& frame) = 0;
  // The file's frame rate; 0 where it does not say.
  virtual double fps() const = 0;
};

class VideoFiles {
 public:
  virtual ~VideoFiles() = default;
  // cv::VideoCapture on a file; null where OpenCV cannot open it.
  virtual std::unique_ptr<VideoReader> open(const std::string& path) const = 0;
};

// Each plugin, loaded on the first call (thread-safe) and kept for the process's life. Throws
// StartupError naming every place it looked and why each failed where it cannot be loaded.
// Looked for in $KEYFLEET_PLUGIN_DIR, then <the executable's folder>/../lib/keyfleet, then the
// build folder it was built in.
const ImageFiles& image_files();
const VideoFiles& video_files();

// A plugin's file name and the function it exports (returning a pointer to the interface).
struct Plugin {
  const char* file;
  const char* entry;
};
inline constexpr Plugin kImagesPlugin{"libkeyfleet_opencv_images.so", "keyfleet_image_files_v1"};
inline constexpr Plugin kVideoPlugin{"libkeyfleet_opencv_video.so", "keyfleet_video_files_v1"};

// The plugin's entry's result from the first of `files` that loads it (what image_files() and
// video_files() do with their places); throws StartupError naming each file and why it failed
// where none does.
const void* load_plugin(const Plugin& plugin, const std::vector<std::string>& files);
// The places a plugin is looked for, in order.
std::vector<std::string> plugin_places(const Plugin& plugin);

}  // namespace keyfleet
