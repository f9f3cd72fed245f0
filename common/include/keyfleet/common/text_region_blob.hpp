#pragma once
// Text regions as one SQLite BLOB (the agent's outbox and the station's store): 8 bytes a
// region, x, y, w, h as little-endian 16-bit integers.
#include <cstdint>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace keyfleet {

std::vector<std::uint8_t> text_regions_blob(const std::vector<TextRegion>& regions);
// Trailing bytes short of a whole region are ignored.
std::vector<TextRegion> text_regions_from_blob(const std::vector<std::uint8_t>& blob);

}  // namespace keyfleet
