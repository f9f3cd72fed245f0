// libkeyfleet_opencv_video.so: OpenCV's videoio behind keyfleet::VideoFiles
// (keyfleet/common/opencv_io.hpp), so that only the processes that read video files load it.
#include <opencv2/videoio.hpp>

#include <utility>

#include "keyfleet/common/opencv_io.hpp"

namespace {

class VideoFile final : public keyfleet::VideoReader {
 public:
  explicit VideoFile(cv::VideoCapture capture) : capture_(std::move(capture)) {}
  bool read(cv::Mat& frame) override { return capture_.read(frame) && !frame.empty(); }
  double fps() const override { return capture_.get(cv::CAP_PROP_FPS); }

 private:
  cv::VideoCapture capture_;
};

class OpenCvVideoFiles final : public keyfleet::VideoFiles {
 public:
  std::unique_ptr<keyfleet::VideoReader> open(const std::string& path) const override {
    cv::VideoCapture capture;
    if (!capture.open(path)) return nullptr;
    return std::make_unique<VideoFile>(std::move(capture));
  }
};

}  // namespace

extern "C" __attribute__((visibility("default"))) const void* keyfleet_video_files_v1() {
  static const OpenCvVideoFiles files;
  return static_cast<const keyfleet::VideoFiles*>(&files);
}
