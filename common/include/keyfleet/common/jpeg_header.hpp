#pragma once
// What a JPEG asks of its decoder, read from its markers without decoding anything: so that a
// hostile sample is refused before the decoder allocates or loops on its behalf.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"

namespace keyfleet {

struct ImageSize {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
};

// The coding process a JPEG's start-of-frame marker (SOF0..SOF15) names.
enum class JpegProcess {
  kBaseline,      // SOF0
  kExtended,      // SOF1: extended sequential, Huffman
  kProgressive,   // SOF2: progressive, Huffman
  kLossless,      // SOF3
  kHierarchical,  // SOF5-SOF7: differential (hierarchical), Huffman
  kArithmetic,    // SOF9-SOF15: any process with arithmetic coding
};
std::string to_string(JpegProcess process);

struct JpegComponent {
  std::uint8_t id = 0;
  std::uint8_t horizontal_sampling = 0;  // 1..4 in a valid file
  std::uint8_t vertical_sampling = 0;
};

struct JpegHeader {
  std::uint8_t sof_marker = 0;  // 0xC0..0xCF
  JpegProcess process = JpegProcess::kBaseline;
  int precision = 0;  // bits per sample
  ImageSize size;
  std::vector<JpegComponent> components;
  std::uint32_t scans = 0;            // SOS markers, those after entropy-coded data included
  std::uint32_t restart_markers = 0;  // RSTn markers inside entropy-coded data
};

struct JpegInspection {
  JpegHeader header;
  std::string error;  // why the stream is not a complete JPEG; empty when it is
  bool ok() const { return error.empty(); }
};

// Walks every marker from start-of-image to end-of-image, skipping entropy-coded data (stuffed
// 0xFF00 bytes, RSTn markers, fill bytes) to count the scans. Linear in the size, no allocation
// beyond the component list; never throws. An error names what is wrong and where.
JpegInspection inspect_jpeg(const std::vector<std::uint8_t>& bytes);

// The frame size from the start-of-frame header alone (the rest of the stream is not read);
// nullopt when there is no valid one before it.
std::optional<ImageSize> jpeg_dimensions(const std::vector<std::uint8_t>& bytes);

// Why the station would not decode this JPEG cheaply, against `limits`: a coding process other
// than baseline, extended sequential or progressive Huffman, a precision other than 8 bits,
// other than 1 or 3 components, invalid sampling factors, dimensions or pixels beyond the
// limits, more scans than max_scans, or more pixels per compressed byte than
// max_pixels_per_byte. Each reason names the value and the limit. nullopt: decode it.
std::optional<std::string> find_jpeg_cost_problem(const JpegHeader& header,
                                                  std::size_t compressed_bytes,
                                                  const StationLimits& limits);

}  // namespace keyfleet
