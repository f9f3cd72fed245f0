#pragma once
// The text-reading seam of the ground station: words (text, confidence, box) read from a
// keyframe. Real engines use Tesseract 5; tests may substitute their own reader.
#include <opencv2/core.hpp>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"

namespace keyfleet::station {

struct ReadWord {
  std::string text;      // UTF-8
  float confidence = 0;  // 0..1
  cv::Rect box;          // in the input image's pixels
  // The word's quadrilateral (clockwise from its top-left corner) where the engine knows it,
  // for slanted text; all zero where it does not (then `box` is the outline).
  std::array<cv::Point2f, 4> quad{};
};

// The corners of `rect`, clockwise from its top-left.
std::array<cv::Point2f, 4> corners_of(const cv::Rect& rect);

// `word.quad` where it has an area, else the corners of `word.box`.
std::array<cv::Point2f, 4> outline_of(const ReadWord& word);

// An engine's fetched models are not installed (the files scripts/fetch_ppocr.sh downloads and
// converts): the one start-up error the station's fallback_engine stands in for.
class EngineModelsMissing : public StartupError {
 public:
  using StartupError::StartupError;
};

class TextReader {
 public:
  virtual ~TextReader() = default;
  // Never throws on a bad image (empty, tiny, wrong type): returns no words.
  virtual std::vector<ReadWord> read(const cv::Mat& bgr) = 0;
  // The same with the robot's text regions (in `bgr`'s pixels, checked to lie inside it) as
  // hints; engines that cannot use them read the whole image.
  virtual std::vector<ReadWord> read_with_hints(const cv::Mat& bgr,
                                                const std::vector<cv::Rect>& hints) {
    (void)hints;
    return read(bgr);
  }
  virtual std::string name() const = 0;
};

// The engine `config.engine` names (`enabled` is the caller's business). Throws StartupError on
// an unknown engine, a setting out of range, missing or unreadable traineddata or a bad model.
std::unique_ptr<TextReader> make_text_reader(const TextReadingConfig& config);

// The engine names make_text_reader accepts, in the order `keyfleet ocr eval` compares them.
std::vector<std::string> text_reader_engines();

// The junk filter shared by the engines: at least `min_word_length` characters and
// `min_word_height` pixels, confidence at least `min_confidence`, half or more letters/digits.
bool keep_word(const ReadWord& word, const TextReadingConfig& config);

// Whether `box` comes within `margin` pixels of the edge of an image of `size` (a word the frame
// cuts); never for a negative margin.
bool cut_by_frame(const cv::Rect& box, const cv::Size& size, int margin);

}  // namespace keyfleet::station
