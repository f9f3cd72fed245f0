#pragma once
// ICDAR 2015 end-to-end evaluation of text readers ("Incidental Scene Text", task 4.4):
// one-to-one matching of detected and ground-truth words by polygon IoU >= 0.5 (the GT
// quadrilateral against the detection's outline) and case-insensitive transcription; GT words
// "###" are "don't care". Also word accuracy on cropped words, and the readers of the two
// ground-truth formats in the shared data.
#include <opencv2/core.hpp>

#include <array>
#include <string>
#include <vector>

#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::eval {

struct GtWord {
  std::array<cv::Point2f, 4> quad;  // x1,y1 .. x4,y4 as in the file
  std::string text;
  bool dont_care = false;  // "###": illegible
};

struct EndToEndParams {
  double min_iou = 0.5;
  // A detection that is not matched and covers a don't-care word by more than this fraction
  // of its own area is ignored (neither TP nor FP), as in the official script.
  double dont_care_overlap = 0.5;
  // As the official script: a GT word's first or last character among !?.:,*"()·[]/' may be
  // missing from the detection ("[06]" matches "06").
  bool allow_gt_edge_punctuation = true;
};

struct EndToEndCounts {
  std::size_t matched = 0;     // true positives
  std::size_t gt_words = 0;    // care GT words
  std::size_t detections = 0;  // detections not ignored as don't care
  EndToEndCounts& operator+=(const EndToEndCounts& other);
  double recall() const;
  double precision() const;
  double f_score() const;  // harmonic mean; 0 when both are 0
};

// Polygon IoU of two quadrilaterals (their convex hulls), and of a quadrilateral and a rectangle.
// A detection is compared by its outline (station::outline_of: its quad, else its box).
double quad_iou(const std::array<cv::Point2f, 4>& a, const std::array<cv::Point2f, 4>& b);
double quad_rect_iou(const std::array<cv::Point2f, 4>& quad, const cv::Rect& rect);

// The ICDAR transcription rule (case-insensitive, see EndToEndParams).
bool transcriptions_match(const std::string& gt, const std::string& detected,
                          bool allow_gt_edge_punctuation = true);

// Scores one image. Matching keeps, among pairs with IoU >= min_iou and matching text, the
// highest-IoU pairs first, each word and detection used once.
EndToEndCounts match_end_to_end(const std::vector<GtWord>& truth,
                                const std::vector<station::ReadWord>& detections,
                                const EndToEndParams& params = {});

// `icdar2015/*/gt/gt_img_N.txt`: "x1,y1,...,x4,y4,transcription" per line, optional UTF-8
// BOM, transcription may hold commas. Throws StartupError if the file cannot be read or a
// line is malformed.
std::vector<GtWord> read_icdar_gt(const std::string& path);

struct CroppedWord {
  std::string image_path;  // absolute or relative to the working directory
  std::string text;
};

// mmocr `labels.json` (data_list[].img_path under `imgs/`, instances[0].text). Throws
// StartupError on a missing or malformed file.
std::vector<CroppedWord> read_mmocr_labels(const std::string& labels_json);

// ICDAR 2015 word-recognition ground truth: `word_N.png, "TEXT"` a line (a byte-order mark
// first; \" is a quote inside the text); images next to it. Throws StartupError on a bad line.
std::vector<CroppedWord> read_icdar_word_gt(const std::string& gt_txt);

// The cropped words of a folder in either format (labels.json, else gt.txt).
std::vector<CroppedWord> read_word_set(const std::string& folder);

// What a reader says a cropped word is: its words left to right, joined without spaces.
std::string cropped_word_reading(const std::vector<station::ReadWord>& words);

}  // namespace keyfleet::eval
