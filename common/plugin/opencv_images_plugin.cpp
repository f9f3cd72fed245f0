// libkeyfleet_opencv_images.so: OpenCV's imgcodecs behind keyfleet::ImageFiles
// (keyfleet/common/opencv_io.hpp), so that only the processes that need it load it.
#include <opencv2/imgcodecs.hpp>

#include "keyfleet/common/opencv_io.hpp"

namespace {

class OpenCvImageFiles final : public keyfleet::ImageFiles {
 public:
  cv::Mat decode(const std::vector<std::uint8_t>& bytes, int flags) const override {
    return cv::imdecode(bytes, flags);
  }
  bool encode(const std::string& extension, const cv::Mat& image, const std::vector<int>& params,
              std::vector<std::uint8_t>& out) const override {
    try {
      return cv::imencode(extension, image, out, params);
    } catch (const cv::Exception&) {
      return false;
    }
  }
};

}  // namespace

extern "C" __attribute__((visibility("default"))) const void* keyfleet_image_files_v1() {
  static const OpenCvImageFiles files;
  return static_cast<const keyfleet::ImageFiles*>(&files);
}
