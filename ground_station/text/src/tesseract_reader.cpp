#include <algorithm>

#include "image_prep.hpp"
#include "keyfleet/vision/image_helpers.hpp"
#include "line_reading.hpp"
#include "readers.hpp"

namespace keyfleet::station {

TesseractReader::TesseractReader(const TextReadingConfig& params)
    : params_(params),
      ocr_(params.tesseract.tessdata_dir, params.tesseract.language,
           params.tesseract.thresholding_method) {}

std::vector<ReadWord> TesseractReader::read(const cv::Mat& bgr) {
  const cv::Mat grey = vision::to_grey(bgr, 4);
  if (grey.empty()) return {};
  std::vector<ReadWord> words;
  if (std::max(grey.cols, grey.rows) < kMaxCropLongSide) {
    words =
        read_line(ocr_, grey, cv::Rect(0, 0, grey.cols, grey.rows), params_.tesseract.line_height);
  } else {
    const double scale = reading_scale(grey.size(), params_.min_long_side, params_.max_long_side);
    words = ocr_.words(rescaled(grey, scale), TesseractOcr::Layout::kSparseText);
    map_back(words, scale, {0, 0}, cv::Rect(0, 0, grey.cols, grey.rows));
  }
  std::vector<ReadWord> kept;
  for (auto& w : words)
    if (keep_word(w, params_)) kept.push_back(std::move(w));
  return kept;
}

}  // namespace keyfleet::station
