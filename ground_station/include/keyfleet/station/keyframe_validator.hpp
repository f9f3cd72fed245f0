#pragma once
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::station {

// Checks a received keyframe before the station trusts it: robot id format, encoding,
// sizes (claimed, in the JPEG header, and decoded, all against the limits), and that the
// image decodes. Returns the reason for rejection, or nullopt when it is acceptable.
std::optional<std::string> find_keyframe_problem(const Keyframe& keyframe,
                                                 const StationLimits& limits,
                                                 const ImageCodec& codec);

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

// A string from a sample the station does not trust (a rejected keyframe's robot id or
// encoding) as it may go into logs, the database, the mission log and the JSON reports: its
// first `max_bytes` bytes, printable ASCII kept and every other byte (control characters,
// invalid UTF-8) and the backslash written as \xNN.
std::string printable_text(const std::string& raw, std::size_t max_bytes = 64);

}  // namespace keyfleet::station
