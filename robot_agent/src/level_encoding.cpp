#include "keyfleet/agent/level_encoding.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace keyfleet::agent {
namespace {

cv::Size scaled_size(const cv::Mat& frame, double scale) {
  return {std::max(1, static_cast<int>(std::lround(frame.cols * scale))),
          std::max(1, static_cast<int>(std::lround(frame.rows * scale)))};
}

}  // namespace

std::vector<TextRegion> scale_regions(const std::vector<TextRegion>& regions, double sx, double sy,
                                      cv::Size size) {
  std::vector<TextRegion> out;
  for (const auto& r : regions) {
    const int x0 = std::clamp(static_cast<int>(std::floor(r.x * sx)), 0, size.width - 1);
    const int y0 = std::clamp(static_cast<int>(std::floor(r.y * sy)), 0, size.height - 1);
    const int x1 = std::clamp(static_cast<int>(std::ceil((r.x + r.w) * sx)), x0 + 1, size.width);
    const int y1 = std::clamp(static_cast<int>(std::ceil((r.y + r.h) * sy)), y0 + 1, size.height);
    out.push_back({static_cast<std::uint16_t>(x0), static_cast<std::uint16_t>(y0),
                   static_cast<std::uint16_t>(x1 - x0), static_cast<std::uint16_t>(y1 - y0)});
  }
  return out;
}

EncodedFrame encode_at_level(const cv::Mat& frame, const std::vector<TextRegion>& regions,
                             const SendLevel& level, bool text_aware, int text_margin_px,
                             const ImageCodec& codec) {
  EncodedFrame out;
  if (level.scale >= 1.0) {
    out.image = codec.encode_at_quality(frame, level.jpeg_quality);
    out.width = static_cast<std::uint32_t>(frame.cols);
    out.height = static_cast<std::uint32_t>(frame.rows);
    out.text_regions = regions;
    return out;
  }
  const cv::Size size = scaled_size(frame, level.scale);
  cv::Mat small;
  cv::resize(frame, small, size, 0, 0, cv::INTER_AREA);
  if (!text_aware || regions.empty()) {
    out.image = codec.encode_at_quality(small, level.jpeg_quality);
    out.width = static_cast<std::uint32_t>(size.width);
    out.height = static_cast<std::uint32_t>(size.height);
    out.text_regions = scale_regions(regions, double(size.width) / frame.cols,
                                     double(size.height) / frame.rows, size);
    return out;
  }
  cv::Mat composite;
  cv::resize(small, composite, frame.size(), 0, 0, cv::INTER_LINEAR);
  const cv::Rect bounds(0, 0, frame.cols, frame.rows);
  for (const auto& r : regions) {
    const cv::Rect box = cv::Rect(r.x - text_margin_px, r.y - text_margin_px,
                                  r.w + 2 * text_margin_px, r.h + 2 * text_margin_px) &
                         bounds;
    if (box.area() > 0) frame(box).copyTo(composite(box));
  }
  out.image = codec.encode_at_quality(composite, level.jpeg_quality);
  out.width = static_cast<std::uint32_t>(frame.cols);
  out.height = static_cast<std::uint32_t>(frame.rows);
  out.text_regions = regions;
  return out;
}

}  // namespace keyfleet::agent
