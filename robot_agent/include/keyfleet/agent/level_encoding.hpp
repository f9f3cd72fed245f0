#pragma once
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

#include "keyfleet/agent/send_controller.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// A frame encoded at one rung of the send ladder.
struct EncodedFrame {
  std::vector<std::uint8_t> image;
  std::uint32_t width = 0, height = 0;
  std::vector<TextRegion> text_regions;  // in the encoded image's pixels
};

// The frame at `level`'s JPEG quality and scale (density does not change the encoding).
// Scaled: the frame is resized (area averaging) and its text regions scaled with it, rounded
// outwards. Text-aware (and scaled, with text regions): the frame keeps its size, the background
// carries only the scaled frame's detail (resized down and back up) while the text regions,
// padded by `text_margin_px`, keep every pixel; the regions stay as they are. A text-aware
// frame without text regions is sent scaled.
EncodedFrame encode_at_level(const cv::Mat& frame, const std::vector<TextRegion>& regions,
                             const SendLevel& level, bool text_aware, int text_margin_px,
                             const ImageCodec& codec);

// Regions scaled by (sx, sy) into an image of `size`, rounded outwards, each at least 1x1.
std::vector<TextRegion> scale_regions(const std::vector<TextRegion>& regions, double sx, double sy,
                                      cv::Size size);

}  // namespace keyfleet::agent
