#pragma once
#include <optional>
#include <string>

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

// A string from a sample the station does not trust (a rejected keyframe's robot id or
// encoding) as it may go into logs, the database, the mission log and the JSON reports: its
// first `max_bytes` bytes, printable ASCII kept and every other byte (control characters,
// invalid UTF-8) and the backslash written as \xNN.
std::string printable_text(const std::string& raw, std::size_t max_bytes = 64);

}  // namespace keyfleet::station
