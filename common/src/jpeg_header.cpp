#include "keyfleet/common/jpeg_header.hpp"

#include <cstdio>
#include <cstring>

namespace keyfleet {
namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr std::uint8_t kStartOfImage = 0xD8;
constexpr std::uint8_t kEndOfImage = 0xD9;
constexpr std::uint8_t kStartOfScan = 0xDA;
constexpr std::uint8_t kTemporary = 0x01;
// libjpeg refuses an interleaved scan whose MCU holds more blocks than this (the standard's bound).
constexpr int kMaxBlocksPerMcu = 10;

bool is_start_of_frame(std::uint8_t m) {
  return m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
}
bool is_restart(std::uint8_t m) { return m >= 0xD0 && m <= 0xD7; }

std::size_t be16(const Bytes& b, std::size_t at) { return (std::size_t{b[at]} << 8) | b[at + 1]; }

JpegProcess process_of(std::uint8_t sof) {
  if (sof >= 0xC9) return JpegProcess::kArithmetic;
  switch (sof) {
    case 0xC0: return JpegProcess::kBaseline;
    case 0xC1: return JpegProcess::kExtended;
    case 0xC2: return JpegProcess::kProgressive;
    case 0xC3: return JpegProcess::kLossless;
    default: return JpegProcess::kHierarchical;
  }
}

std::string marker_name(std::uint8_t m) {
  char text[8];
  std::snprintf(text, sizeof text, "0xFF%02X", m);
  return text;
}
std::string at_byte(std::size_t pos) { return " at byte " + std::to_string(pos); }
std::string size_text(ImageSize s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}

// The start-of-frame segment whose length field is at `pos`.
std::string read_frame(const Bytes& b, std::size_t pos, std::size_t length, std::uint8_t marker,
                       JpegHeader& h) {
  if (length < 8) return "corrupt JPEG: start-of-frame header too short" + at_byte(pos);
  h.sof_marker = marker;
  h.process = process_of(marker);
  h.precision = b[pos + 2];
  h.size.height = static_cast<std::uint32_t>(be16(b, pos + 3));
  h.size.width = static_cast<std::uint32_t>(be16(b, pos + 5));
  const std::size_t count = b[pos + 7];
  if (count == 0 || length != 8 + 3 * count)
    return "corrupt JPEG: start-of-frame header of " + std::to_string(length) + " bytes for " +
           std::to_string(count) + " components" + at_byte(pos);
  // A zero height would be given later by a DNL marker, which the station does not take.
  if (h.size.width == 0 || h.size.height == 0)
    return "corrupt JPEG: frame size " + size_text(h.size) + " in the start-of-frame header";
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint8_t sampling = b[pos + 9 + 3 * i];
    h.components.push_back({b[pos + 8 + 3 * i], static_cast<std::uint8_t>(sampling >> 4),
                            static_cast<std::uint8_t>(sampling & 0x0F)});
  }
  return {};
}

// Past the entropy-coded data that starts at `pos`: to the next marker (or the end), counting
// restart markers; stuffed bytes (0xFF00) and fill bytes are data.
std::size_t skip_entropy_coded_data(const Bytes& b, std::size_t pos, JpegHeader& h) {
  const std::size_t n = b.size();
  while (pos < n) {
    const void* ff = std::memchr(b.data() + pos, 0xFF, n - pos);
    if (!ff) return n;
    pos = static_cast<std::size_t>(static_cast<const std::uint8_t*>(ff) - b.data());
    if (pos + 1 >= n) return pos;
    const std::uint8_t next = b[pos + 1];
    if (next == 0x00) {
      pos += 2;
    } else if (is_restart(next)) {
      ++h.restart_markers;
      pos += 2;
    } else if (next == 0xFF) {
      ++pos;
    } else {
      return pos;
    }
  }
  return pos;
}

// Walks the markers from start-of-image; with `frame_only`, stops after the frame header.
std::string walk(const Bytes& b, bool frame_only, JpegHeader& h) {
  const std::size_t n = b.size();
  if (n < 2 || b[0] != 0xFF || b[1] != kStartOfImage) return "not a JPEG: no start-of-image marker";
  const std::string truncated = "truncated JPEG: no end-of-image marker";
  bool have_frame = false;
  std::size_t pos = 2;
  for (;;) {
    if (pos >= n) return truncated;
    if (b[pos] != 0xFF) return "corrupt JPEG: no marker" + at_byte(pos);
    while (pos + 1 < n && b[pos + 1] == 0xFF) ++pos;  // fill bytes before a marker
    if (pos + 1 >= n) return truncated;
    const std::uint8_t marker = b[pos + 1];
    pos += 2;
    if (marker == kEndOfImage) {
      if (!have_frame) return "corrupt JPEG: no start-of-frame header";
      if (h.scans == 0) return "corrupt JPEG: no scan before the end-of-image marker";
      if (pos != n)
        return "corrupt JPEG: " + std::to_string(n - pos) + " bytes after the end-of-image marker";
      return {};
    }
    if (is_restart(marker) || marker == kTemporary) continue;  // markers without a length
    if (marker == kStartOfImage || marker == 0x00)
      return "corrupt JPEG: unexpected marker " + marker_name(marker) + at_byte(pos - 2);
    if (pos + 2 > n) return truncated;
    const std::size_t length = be16(b, pos);
    if (length < 2) return "corrupt JPEG: segment length " + std::to_string(length) + at_byte(pos);
    if (pos + length > n) return truncated;
    if (is_start_of_frame(marker)) {
      if (have_frame) return "corrupt JPEG: a second start-of-frame header" + at_byte(pos - 2);
      const std::string error = read_frame(b, pos, length, marker, h);
      if (!error.empty()) return error;
      have_frame = true;
      if (frame_only) return {};
    } else if (marker == kStartOfScan) {
      if (!have_frame) return "corrupt JPEG: a scan before the start-of-frame header";
      const std::size_t count = length >= 3 ? b[pos + 2] : 0;
      if (count < 1 || count > 4 || length != 6 + 2 * count)
        return "corrupt JPEG: malformed scan header" + at_byte(pos - 2);
      ++h.scans;
      pos = skip_entropy_coded_data(b, pos + length, h);
      continue;
    }
    pos += length;
  }
}

}  // namespace

std::string to_string(JpegProcess process) {
  switch (process) {
    case JpegProcess::kBaseline: return "baseline";
    case JpegProcess::kExtended: return "extended sequential";
    case JpegProcess::kProgressive: return "progressive";
    case JpegProcess::kLossless: return "lossless";
    case JpegProcess::kHierarchical: return "hierarchical";
    case JpegProcess::kArithmetic: return "arithmetic-coded";
  }
  return "?";
}

JpegInspection inspect_jpeg(const std::vector<std::uint8_t>& bytes) {
  JpegInspection result;
  result.error = walk(bytes, false, result.header);
  return result;
}

std::optional<ImageSize> jpeg_dimensions(const std::vector<std::uint8_t>& bytes) {
  JpegHeader header;
  if (!walk(bytes, true, header).empty()) return std::nullopt;
  return header.size;
}

std::optional<std::string> find_jpeg_cost_problem(const JpegHeader& h, std::size_t compressed_bytes,
                                                  const StationLimits& limits) {
  const bool decodable = h.process == JpegProcess::kBaseline ||
                         h.process == JpegProcess::kExtended ||
                         h.process == JpegProcess::kProgressive;
  if (!decodable)
    return "JPEG coding " + to_string(h.process) + " (" + marker_name(h.sof_marker) +
           ") is refused: baseline, extended sequential or progressive Huffman only";
  if (h.precision != 8)
    return "JPEG sample precision " + std::to_string(h.precision) + " bits is refused: 8 only";
  const std::size_t count = h.components.size();
  if (count != 1 && count != 3)
    return "JPEG with " + std::to_string(count) + " components is refused: 1 (grey) or 3 only";
  int blocks = 0;
  for (const JpegComponent& c : h.components) {
    if (c.horizontal_sampling < 1 || c.horizontal_sampling > 4 || c.vertical_sampling < 1 ||
        c.vertical_sampling > 4)
      return "JPEG component " + std::to_string(c.id) + " sampling " +
             std::to_string(c.horizontal_sampling) + "x" + std::to_string(c.vertical_sampling) +
             " outside 1x1..4x4";
    blocks += c.horizontal_sampling * c.vertical_sampling;
  }
  if (count > 1 && blocks > kMaxBlocksPerMcu)
    return "JPEG sampling needs " + std::to_string(blocks) + " blocks per MCU, beyond " +
           std::to_string(kMaxBlocksPerMcu);
  if (h.size.width > limits.max_width || h.size.height > limits.max_height)
    return "JPEG frame " + size_text(h.size) + " exceeds max_width x max_height " +
           size_text({limits.max_width, limits.max_height});
  const std::uint64_t pixels = std::uint64_t{h.size.width} * h.size.height;
  if (pixels > limits.max_pixels)
    return "JPEG frame " + size_text(h.size) + " has " + std::to_string(pixels) +
           " pixels, beyond max_pixels " + std::to_string(limits.max_pixels);
  if (h.scans > static_cast<std::uint32_t>(limits.max_scans))
    return "JPEG (" + to_string(h.process) + ") has " + std::to_string(h.scans) +
           " scans, beyond max_scans " + std::to_string(limits.max_scans);
  const double per_byte =
      static_cast<double>(pixels) / static_cast<double>(compressed_bytes ? compressed_bytes : 1);
  if (per_byte > limits.max_pixels_per_byte) {
    char text[160];
    std::snprintf(text, sizeof text,
                  "JPEG of %llu pixels in %zu bytes (%.0f pixels per byte) exceeds "
                  "max_pixels_per_byte %g",
                  static_cast<unsigned long long>(pixels), compressed_bytes, per_byte,
                  limits.max_pixels_per_byte);
    return std::string(text);
  }
  return std::nullopt;
}

}  // namespace keyfleet
