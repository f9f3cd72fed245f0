#include "keyfleet/station/keyframe_validator.hpp"

#include <algorithm>
#include <cstdio>

namespace keyfleet::station {
namespace {

std::string size_text(std::uint32_t w, std::uint32_t h) {
  return std::to_string(w) + "x" + std::to_string(h);
}

}  // namespace

std::string TextRegionReview::summary() const {
  std::string out;
  const auto add = [&](std::size_t n, const char* what) {
    if (n == 0) return;
    if (!out.empty()) out += ", ";
    out += std::to_string(n) + " " + what;
  };
  add(dropped, "dropped (empty or outside the image)");
  add(clamped, "clamped to the image");
  add(over_limit, "beyond max_text_regions");
  return out;
}

TextRegionReview review_text_regions(const std::vector<TextRegion>& regions, std::uint32_t width,
                                     std::uint32_t height, std::size_t max_regions) {
  TextRegionReview review;
  for (const TextRegion& r : regions) {
    if (r.w == 0 || r.h == 0 || r.x >= width || r.y >= height) {
      ++review.dropped;
      continue;
    }
    if (review.regions.size() >= max_regions) {
      ++review.over_limit;
      continue;
    }
    TextRegion fit = r;
    fit.w = std::uint16_t(std::min<std::uint32_t>(r.w, width - r.x));
    fit.h = std::uint16_t(std::min<std::uint32_t>(r.h, height - r.y));
    if (!(fit == r)) ++review.clamped;
    review.regions.push_back(fit);
  }
  return review;
}

std::optional<std::string> find_keyframe_problem(const Keyframe& k, const StationLimits& limits,
                                                 const ImageCodec& codec, cv::Mat* decoded_out) {
  if (!is_valid_robot_id(k.robot_id))
    return "robot id '" + printable_text(k.robot_id) + "' does not match [A-Za-z0-9_-]{1,32}";
  if (k.encoding != codec.encoding())
    return "encoding '" + printable_text(k.encoding, 32) + "' is not " + codec.encoding();
  if (k.image.empty()) return std::string("empty image");
  if (k.image.size() > limits.max_image_bytes)
    return "image of " + std::to_string(k.image.size()) + " bytes exceeds max_image_bytes " +
           std::to_string(limits.max_image_bytes);
  if (k.width == 0 || k.height == 0 || k.width > limits.max_width || k.height > limits.max_height)
    return "claimed size " + size_text(k.width, k.height) + " outside 1x1.." +
           size_text(limits.max_width, limits.max_height);
  // The whole marker walk, then its cost against the limits: only then is the image decoded.
  const JpegInspection jpeg = inspect_jpeg(k.image);
  if (!jpeg.ok()) return jpeg.error;
  const ImageSize header = jpeg.header.size;
  if (header.width != k.width || header.height != k.height)
    return "JPEG header says " + size_text(header.width, header.height) + ", sample claims " +
           size_text(k.width, k.height);
  if (auto cost = find_jpeg_cost_problem(jpeg.header, k.image.size(), limits)) return cost;
  const DecodeResult decoded = codec.decode(k.image);
  if (!decoded.ok()) return decoded.error;
  if (static_cast<std::uint32_t>(decoded.image.cols) != k.width ||
      static_cast<std::uint32_t>(decoded.image.rows) != k.height)
    return "decoded size " +
           size_text(static_cast<std::uint32_t>(decoded.image.cols),
                     static_cast<std::uint32_t>(decoded.image.rows)) +
           " differs from the claimed " + size_text(k.width, k.height);
  if (decoded_out) *decoded_out = decoded.image;
  return std::nullopt;
}

}  // namespace keyfleet::station
