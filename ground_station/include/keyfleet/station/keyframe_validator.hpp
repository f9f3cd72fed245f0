#pragma once
#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/jpeg_header.hpp"
#include "keyfleet/common/printable_text.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::station {

// Checks a received keyframe before the station trusts it: robot id format, encoding,
// sizes (claimed, in the JPEG header, and decoded, all against the limits), the JPEG's markers
// walked and its decoding cost bounded (coding process, scans, pixels, pixels per byte:
// find_jpeg_cost_problem), and only then that the image decodes. Returns the reason for
// rejection, or nullopt when it is acceptable; then `decoded` (when given) holds the pixels, which
// the analysis reads instead of decoding the JPEG again.
std::optional<std::string> find_keyframe_problem(const Keyframe& keyframe,
                                                 const StationLimits& limits,
                                                 const ImageCodec& codec,
                                                 cv::Mat* decoded = nullptr);

// A keyframe's text regions made fit to use: each one that is empty or starts outside the
// image dropped, each one that reaches past the image's edge clamped to it, and at most
// `max_regions` kept (the first). The regions are hints: however wrong, they never make the
// keyframe unacceptable.
struct TextRegionReview {
  std::vector<TextRegion> regions;  // what is fit to use
  std::size_t dropped = 0;          // empty or outside the image
  std::size_t clamped = 0;          // cut at the image's edge
  std::size_t over_limit = 0;       // beyond max_regions
  bool changed() const { return dropped + clamped + over_limit > 0; }
  std::string summary() const;  // "3 dropped (empty or outside the image), 1 clamped ..."
};
TextRegionReview review_text_regions(const std::vector<TextRegion>& regions, std::uint32_t width,
                                     std::uint32_t height, std::size_t max_regions);

using ::keyfleet::printable_text;

}  // namespace keyfleet::station
