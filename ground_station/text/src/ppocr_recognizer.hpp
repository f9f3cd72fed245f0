#pragma once
// PP-OCRv4 text-line recogniser (SVTR-LCNet with a CTC head) run through OpenCV DNN.
//
// OpenCV 4.6 needs one converted file per input width (ppocr_rec_w<W>.onnx, height 48; the
// station's Latin reader ppocr_rec_latin_w<W>.onnx, the classifier cut to the Latin classes). A
// line is cut out of the image along its quad, scaled to height 48 keeping its aspect, put into the
// narrowest width that holds it (padded right; longer lines are squeezed into the widest), read
// with greedy CTC and split into words at spaces, each with a box interpolated along the quad.
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ppocr_detector.hpp"

namespace keyfleet::station {

struct RecognizedWord {
  std::string text;      // UTF-8
  float confidence = 0;  // mean over its characters of the winning class probability (among
                         // the classes the file holds: the Latin ones in the Latin files)
  TextQuad quad;         // in the pixels of the image the line was cut from
};

struct RecognizedLine {
  std::vector<RecognizedWord> words;
};

namespace ppocr {

// How a line's class probabilities become words.
struct CtcOptions {
  // Classes the decoder may emit (index = class; empty = all). The CTC blank (0) is always
  // allowed. PP-OCRv4's list is mostly Chinese; a Latin-script street reads better without it.
  std::vector<bool> allowed;
  // Besides where the space class wins a step, a word ends between two characters where it
  // reaches this probability (the Chinese model often reads "you know" as "youknow", with the
  // space's probability at 0.2-0.3 between them). 0 = split only where the space wins.
  float space_probability = 0;
};

// The classes of a Latin-script reader: printable ASCII, Latin-1 and Latin Extended letters, and
// the space. `classes` as PpocrRecognizer::classes().
std::vector<bool> latin_classes(const std::vector<std::string>& classes);

}  // namespace ppocr

struct RecognizerOptions {
  bool latin_only = true;       // emit only ppocr::latin_classes
  float space_probability = 0;  // as CtcOptions::space_probability
  // keyfleet's stand-in layers (in float: OpenCV's probabilities to float rounding).
  vision::DnnLayers layers = vision::DnnLayers::in_float();
};

class PpocrRecognizer {
 public:
  static constexpr int kHeight = 48;

  // `models_by_width`: input width -> converted file; `keys_path`: the character list (one per
  // line). Loads every file and checks each network with one pass. Throws StartupError naming
  // the file that is missing or unusable.
  PpocrRecognizer(const std::map<int, std::string>& models_by_width, const std::string& keys_path,
                  RecognizerOptions options = {});

  // Cuts `quad` out of `image` and reads it. Never throws: nothing on a bad image or quad.
  std::optional<RecognizedLine> recognize(const cv::Mat& image, const TextQuad& quad);

  // The characters: index 0 is the CTC blank, then the keys file in order, then the space.
  const std::vector<std::string>& classes() const { return classes_; }

 private:
  int bucket_width(const cv::Mat& crop) const;
  cv::Mat class_probabilities(const cv::Mat& blob, int width);

  std::map<int, cv::dnn::Net> nets_;  // input width -> network
  std::vector<std::string> classes_;
  ppocr::CtcOptions options_;
};

namespace ppocr {

// Perspective cut of `quad` to an upright rectangle (cubic, replicated border, as PaddleOCR);
// a cut at least 1.5 times taller than wide is turned 90 degrees counter-clockwise (vertical
// text), which `rotated` reports. Empty for a bad image or a degenerate or absurd quad.
cv::Mat crop_quad(const cv::Mat& image, const TextQuad& quad, bool* rotated = nullptr);

// Greedy CTC decoding of `probs` (time steps x classes, CV_32F): the best allowed class per
// step, repeats collapsed, blanks (class 0) dropped, words split at spaces (" " or U+3000),
// also where a space is likely though not the best class (`options`). The line was `content_width`
// of the network's `input_width` columns; a word's quad is the part of `quad` its time steps cover
// (`rotated`: the cut was turned, text runs down the quad).
RecognizedLine ctc_decode(const cv::Mat& probs, const std::vector<std::string>& classes,
                          int input_width, int content_width, const TextQuad& quad, bool rotated,
                          const CtcOptions& options = {});

}  // namespace ppocr
}  // namespace keyfleet::station
