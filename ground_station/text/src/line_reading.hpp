#pragma once
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/station/text/text_reader.hpp"
#include "tesseract_ocr.hpp"

namespace keyfleet::station {

// Reads `region` of `grey` as one line of text: scaled so its height is `line_height` px,
// padded with its own border (Tesseract misses glyphs touching the edge), boxes mapped back
// to `grey`'s pixels. Words are not filtered.
std::vector<ReadWord> read_line(TesseractOcr& ocr, const cv::Mat& grey, cv::Rect region,
                                int line_height);

// Small images are crops of one word or line, not scenes (longer side in pixels).
constexpr int kMaxCropLongSide = 400;

}  // namespace keyfleet::station
