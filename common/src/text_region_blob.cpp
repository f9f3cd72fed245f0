#include "keyfleet/common/text_region_blob.hpp"

namespace keyfleet {
namespace {

void put(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v & 0xFF));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}

std::uint16_t get(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }

}  // namespace

std::vector<std::uint8_t> text_regions_blob(const std::vector<TextRegion>& regions) {
  std::vector<std::uint8_t> out;
  out.reserve(regions.size() * 8);
  for (const auto& r : regions) put(out, r.x), put(out, r.y), put(out, r.w), put(out, r.h);
  return out;
}

std::vector<TextRegion> text_regions_from_blob(const std::vector<std::uint8_t>& blob) {
  std::vector<TextRegion> out;
  for (std::size_t i = 0; i + 8 <= blob.size(); i += 8) {
    const std::uint8_t* p = blob.data() + i;
    out.push_back({get(p), get(p + 2), get(p + 4), get(p + 6)});
  }
  return out;
}

}  // namespace keyfleet
