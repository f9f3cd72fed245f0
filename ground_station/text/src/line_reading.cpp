#include "line_reading.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>

#include "image_prep.hpp"

namespace keyfleet::station {

std::vector<ReadWord> read_line(TesseractOcr& ocr, const cv::Mat& grey, cv::Rect region,
                                int line_height) {
  region &= cv::Rect(0, 0, grey.cols, grey.rows);
  if (region.width < 4 || region.height < 4) return {};
  const double scale = std::clamp(double(line_height) / region.height, 0.25, 8.0);
  const cv::Mat line = rescaled(grey(region), scale);
  const int border = std::max(4, line.rows / 4);
  cv::Mat padded;
  cv::copyMakeBorder(line, padded, border, border, border, border, cv::BORDER_REPLICATE);
  std::vector<ReadWord> words = ocr.words(padded, TesseractOcr::Layout::kSingleLine);
  for (auto& w : words) w.box -= cv::Point(border, border);
  map_back(words, scale, region.tl(), cv::Rect(0, 0, grey.cols, grey.rows));
  return words;
}

}  // namespace keyfleet::station
