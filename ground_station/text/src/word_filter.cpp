#include <opencv2/imgproc.hpp>

#include <cctype>
#include <vector>

#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::station {

std::array<cv::Point2f, 4> corners_of(const cv::Rect& rect) {
  const auto x0 = float(rect.x), y0 = float(rect.y);
  const auto x1 = float(rect.x + rect.width), y1 = float(rect.y + rect.height);
  return {cv::Point2f(x0, y0), cv::Point2f(x1, y0), cv::Point2f(x1, y1), cv::Point2f(x0, y1)};
}

std::array<cv::Point2f, 4> outline_of(const ReadWord& word) {
  const std::vector<cv::Point2f> corners(word.quad.begin(), word.quad.end());
  return cv::contourArea(corners) > 0 ? word.quad : corners_of(word.box);
}

bool cut_by_frame(const cv::Rect& box, const cv::Size& size, int margin) {
  return margin >= 0 &&
         (box.x <= margin || box.y <= margin || box.x + box.width >= size.width - margin ||
          box.y + box.height >= size.height - margin);
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
