#include <cctype>

#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::station {

bool keep_word(const ReadWord& word, const TextReadingConfig& config) {
  // Compared in float, the precision the engines report confidences in.
  if (word.confidence < float(config.min_confidence) || word.box.area() <= 0) return false;
  if (word.box.height < config.min_word_height) return false;
  int code_points = 0, alphanumeric = 0;
  for (const char c : word.text) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte & 0xC0) == 0x80) continue;  // UTF-8 continuation byte
    ++code_points;
    // Non-ASCII code points count as letters (accented words are words).
    if (byte >= 0x80 || std::isalnum(byte)) ++alphanumeric;
  }
  // At least half letters or digits: "[06]" and "03/09/2009" stay, "|", "~-=" and "a/|" go.
  return code_points >= config.min_word_length && alphanumeric > 0 &&
         2 * alphanumeric >= code_points;
}

}  // namespace keyfleet::station
