#include <opencv2/imgproc.hpp>

#include <cctype>
#include <vector>

#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::station {

std::array<cv::Point2f, 4> outline_of(const ReadWord& word) {
  const std::vector<cv::Point2f> corners(word.quad.begin(), word.quad.end());
  if (cv::contourArea(corners) > 0) return word.quad;
  const auto x0 = float(word.box.x), y0 = float(word.box.y);
  const auto x1 = float(word.box.x + word.box.width), y1 = float(word.box.y + word.box.height);
  return {cv::Point2f(x0, y0), cv::Point2f(x1, y0), cv::Point2f(x1, y1), cv::Point2f(x0, y1)};
}

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
