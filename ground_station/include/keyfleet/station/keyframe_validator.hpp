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

}  // namespace keyfleet::station
