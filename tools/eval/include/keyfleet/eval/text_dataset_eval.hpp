#pragma once
// Runs a station::TextReader over the shared data sets and times it (for `keyfleet ocr eval`, tests
// and benchmarks).
#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "keyfleet/eval/text_eval.hpp"
#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::eval {

struct EndToEndResult {
  EndToEndCounts counts;
  std::size_t images = 0;
  double median_ms = 0;     // per image, wall clock (reading only)
  std::uint64_t bytes = 0;  // sent through a PhotoLink, all images; 0 without one
};

// What the station receives for a photo sent over a link (photo_encoding.hpp): the decoded
// image, the photo's pixels per received pixel (sx, sy; 1 when the size is kept), its bytes.
struct ReceivedPhoto {
  cv::Mat image;
  double sx = 1, sy = 1;
  std::size_t bytes = 0;
};
using PhotoLink = std::function<ReceivedPhoto(const cv::Mat& photo)>;

// `set_dir` holds images/img_N.jpg and gt/gt_img_N.txt. `max_images` 0 = all (sorted by N).
// With `link`, each photo is read as the link delivers it, the words mapped back to the photo's
// pixels before they are matched. Throws StartupError if the folder or a ground-truth file is
// missing or unreadable.
EndToEndResult evaluate_end_to_end(station::TextReader& reader, const std::string& set_dir,
                                   std::size_t max_images = 0, const EndToEndParams& params = {},
                                   const PhotoLink& link = {});

struct WordAccuracyResult {
  std::size_t words = 0;
  std::size_t correct = 0;  // reading equals the label, case-insensitively
  double median_ms = 0;     // per word, wall clock
  double accuracy() const { return words ? double(correct) / double(words) : 0.0; }
};

// `words_dir` holds a word set (read_word_set). `max_words` 0 = all, else the first ones.
// Throws StartupError if the set or one of its images is missing.
WordAccuracyResult evaluate_cropped_words(station::TextReader& reader, const std::string& words_dir,
                                          std::size_t max_words = 0);

// Median wall-clock milliseconds of `repetitions` reads of `image` (after one warm-up read).
double median_read_ms(station::TextReader& reader, const cv::Mat& image, int repetitions);

}  // namespace keyfleet::eval
