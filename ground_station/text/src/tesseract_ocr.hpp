#pragma once
// One Tesseract 5 instance (LSTM engine) behind a narrow interface. Not thread-safe: each
// reader owns its own.
#include <opencv2/core.hpp>

#include <memory>
#include <string>
#include <vector>

#include "keyfleet/station/text/text_reader.hpp"

namespace tesseract {
class TessBaseAPI;
}

namespace keyfleet::station {

class TesseractOcr {
 public:
  enum class Layout { kSparseText, kSingleLine, kSingleWord };

  // Throws StartupError naming the folder when `<tessdata_dir>/<language>.traineddata` is
  // missing or Tesseract cannot load it. Empty `tessdata_dir` = Debian's folder.
  TesseractOcr(const std::string& tessdata_dir, const std::string& language,
               int thresholding_method);
  ~TesseractOcr();
  TesseractOcr(const TesseractOcr&) = delete;
  TesseractOcr& operator=(const TesseractOcr&) = delete;

  // Words (unfiltered) of an 8-bit greyscale image, boxes in its pixels, confidence 0..1.
  std::vector<ReadWord> words(const cv::Mat& grey, Layout layout);

 private:
  std::unique_ptr<tesseract::TessBaseAPI> api_;
};

// The folder Debian's tesseract-ocr-eng installs into.
std::string default_tessdata_dir();

}  // namespace keyfleet::station
