// A frame's whole image where the source decoded less (selector.decode_reduce).
#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"

namespace keyfleet::agent {

cv::Size frame_size(const Frame& frame) {
  return frame.full_size.empty() ? frame.image.size() : frame.full_size;
}

cv::Mat full_image(const Frame& frame) {
  if (!frame.encoded || frame.full_size.empty() || frame.image.size() == frame.full_size)
    return frame.image;
  cv::Mat image;
  if (!decode_jpeg_bgr(frame.encoded->data(), frame.encoded->size(), image) ||
      image.size() != frame.full_size)
    return {};
  return image;
}

bool read_frame_image(const std::string& path, int reduce, std::vector<std::uint8_t>& buffer,
                      Frame& frame) {
  if (reduce <= 1) {
    frame.image = read_image_bgr(path, buffer);
    return !frame.image.empty();
  }
  auto bytes = std::make_shared<std::vector<std::uint8_t>>();
  cv::Size full;
  frame.image = read_image_bgr(path, *bytes, reduce, &full);
  if (frame.image.empty()) return false;
  if (frame.image.size() != full) {  // a JPEG decoded at 1/reduce: keep its file for the keyframe
    frame.full_size = full;
    frame.encoded = std::move(bytes);
  }
  return true;
}

}  // namespace keyfleet::agent
