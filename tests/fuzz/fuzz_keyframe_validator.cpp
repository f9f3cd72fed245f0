// The station's checks of a received keyframe (find_keyframe_problem, jpeg_dimensions,
// review_text_regions) on hostile bytes. Input: claimed width and height (2 bytes each, little
// endian), a flags byte (bit 0: bad robot id, bit 1: wrong encoding, bits 2-7: how many text
// regions, read as 8-byte records from the start of the image), then the image bytes.
// Whatever the bytes, the checks answer without crashing; an accepted keyframe's JPEG header
// agrees with its claimed size, and every text region kept lies inside the image.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/station/keyframe_validator.hpp"

namespace {

constexpr std::size_t kHeaderBytes = 5;

std::vector<keyfleet::TextRegion> regions_from(const std::vector<std::uint8_t>& image,
                                               std::size_t count) {
  std::vector<keyfleet::TextRegion> regions;
  for (std::size_t i = 0; i < count && 8 * (i + 1) <= image.size(); ++i) {
    keyfleet::TextRegion r;
    std::memcpy(&r.x, &image[8 * i], 2);
    std::memcpy(&r.y, &image[8 * i + 2], 2);
    std::memcpy(&r.w, &image[8 * i + 4], 2);
    std::memcpy(&r.h, &image[8 * i + 6], 2);
    regions.push_back(r);
  }
  return regions;
}

void check_regions(const keyfleet::Keyframe& k, const keyfleet::StationLimits& limits) {
  const std::size_t max_regions = static_cast<std::size_t>(limits.max_text_regions);
  const auto review =
      keyfleet::station::review_text_regions(k.text_regions, k.width, k.height, max_regions);
  if (review.regions.size() > max_regions) std::abort();
  if (review.regions.size() + review.dropped + review.over_limit != k.text_regions.size())
    std::abort();
  for (const keyfleet::TextRegion& r : review.regions) {
    if (r.w == 0 || r.h == 0) std::abort();
    if (std::uint32_t{r.x} + r.w > k.width || std::uint32_t{r.y} + r.h > k.height) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < kHeaderBytes) return 0;
  static const keyfleet::JpegCodec codec(90);
  const keyfleet::StationLimits limits;

  keyfleet::Keyframe k;
  k.robot_id = "drone_0";
  k.width = std::uint32_t{data[0]} | std::uint32_t{data[1]} << 8;
  k.height = std::uint32_t{data[2]} | std::uint32_t{data[3]} << 8;
  const std::uint8_t flags = data[4];
  if (flags & 1) k.robot_id = "drone/../0";
  if (flags & 2) k.encoding = "png";
  k.image.assign(data + kHeaderBytes, data + size);
  k.text_regions = regions_from(k.image, flags >> 2);

  const auto problem = keyfleet::station::find_keyframe_problem(k, limits, codec);
  if (!problem) {
    const auto header = keyfleet::jpeg_dimensions(k.image);
    if (!header || header->width != k.width || header->height != k.height) std::abort();
  }
  check_regions(k, limits);
  return 0;
}
