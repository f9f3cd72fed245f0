// Frame sources that read recordings: a folder of images, or a video file.
#include <algorithm>
#include <filesystem>
#include <set>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"
#include "keyfleet/common/opencv_io.hpp"

namespace keyfleet::agent {
namespace {

namespace fs = std::filesystem;

std::int64_t stream_time_ns(std::uint64_t index, double fps) {
  return static_cast<std::int64_t>(static_cast<double>(index) * 1e9 / fps);
}

class ImageFolderSource final : public FrameSource {
 public:
  ImageFolderSource(const SourceConfig& config, Logger logger, int decode_reduce)
      : config_(config), logger_(std::move(logger)), decode_reduce_(decode_reduce) {
    static const std::set<std::string> kExtensions = {".png", ".jpg",  ".jpeg", ".bmp",
                                                      ".tif", ".tiff", ".ppm",  ".pgm"};
    std::error_code error;
    if (!fs::is_directory(config.path, error))
      throw StartupError("source.path: image folder '" + config.path +
                         "' does not exist or is not a folder");
    fs::directory_iterator it(config.path, error);
    if (error)
      throw StartupError("source.path: cannot read image folder '" + config.path +
                         "': " + error.message());
    for (const auto& entry : it) {
      std::string ext = entry.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      if (entry.is_regular_file() && kExtensions.count(ext)) files_.push_back(entry.path());
    }
    if (files_.empty())
      throw StartupError("source.path: image folder '" + config.path + "' holds no images");
    std::sort(files_.begin(), files_.end());
  }

  std::optional<Frame> next() override {
    while (position_ < files_.size()) {
      if (config_.max_frames && emitted_ >= config_.max_frames) return std::nullopt;
      const fs::path& file = files_[position_++];
      Frame frame;
      if (!read_frame_image(file.string(), decode_reduce_, file_bytes_, frame)) {
        logger_->error("skipping unreadable image {}", file.string());
        continue;
      }
      frame.index = emitted_;
      frame.capture_time_ns = stream_time_ns(emitted_, config_.fps);
      ++emitted_;
      return frame;
    }
    return std::nullopt;
  }

  double fps() const override { return config_.fps; }
  std::string describe() const override {
    return "image folder " + config_.path + " (" + std::to_string(files_.size()) + " images)";
  }

 private:
  SourceConfig config_;
  Logger logger_;
  std::vector<fs::path> files_;
  int decode_reduce_ = 1;
  std::size_t position_ = 0;
  std::uint64_t emitted_ = 0;
  std::vector<std::uint8_t> file_bytes_;  // the current image's file (whole decodes)
};

class VideoFileSource final : public FrameSource {
 public:
  VideoFileSource(const SourceConfig& config, Logger logger)
      : config_(config), logger_(std::move(logger)) {
    if (!fs::is_regular_file(config.path))
      throw StartupError("source.path: video file '" + config.path + "' does not exist");
    video_ = video_files().open(config.path);
    if (!video_) throw StartupError("source.path: OpenCV cannot open video '" + config.path + "'");
    const double file_fps = video_->fps();
    fps_ = file_fps > 0 && file_fps < 1000 ? file_fps : config.fps;
  }

  std::optional<Frame> next() override {
    if (config_.max_frames && emitted_ >= config_.max_frames) return std::nullopt;
    cv::Mat image;
    if (!video_->read(image)) return std::nullopt;
    Frame frame{emitted_, stream_time_ns(emitted_, fps_), image, std::nullopt};
    ++emitted_;
    return frame;
  }

  double fps() const override { return fps_; }
  std::string describe() const override { return "video " + config_.path; }

 private:
  SourceConfig config_;
  Logger logger_;
  std::unique_ptr<VideoReader> video_;
  double fps_ = 30;
  std::uint64_t emitted_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> make_image_folder_source(const SourceConfig& config, Logger logger,
                                                      int decode_reduce) {
  return std::make_unique<ImageFolderSource>(config, std::move(logger), decode_reduce);
}

std::unique_ptr<FrameSource> make_video_file_source(const SourceConfig& config, Logger logger) {
  return std::make_unique<VideoFileSource>(config, std::move(logger));
}

}  // namespace keyfleet::agent
