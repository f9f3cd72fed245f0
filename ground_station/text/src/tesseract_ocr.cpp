#include "tesseract_ocr.hpp"

#include <tesseract/baseapi.h>
#include <tesseract/resultiterator.h>

#include <filesystem>
#include <sstream>

#include "keyfleet/common/error.hpp"

namespace keyfleet::station {
namespace {

tesseract::PageSegMode page_mode(TesseractOcr::Layout layout) {
  switch (layout) {
    case TesseractOcr::Layout::kSparseText: return tesseract::PSM_SPARSE_TEXT;
    case TesseractOcr::Layout::kSingleLine: return tesseract::PSM_SINGLE_LINE;
    case TesseractOcr::Layout::kSingleWord: return tesseract::PSM_SINGLE_WORD;
  }
  return tesseract::PSM_SPARSE_TEXT;
}

}  // namespace

std::string default_tessdata_dir() { return "/usr/share/tesseract-ocr/5/tessdata"; }

TesseractOcr::TesseractOcr(const std::string& tessdata_dir, const std::string& language,
                           int thresholding_method)
    : api_(std::make_unique<tesseract::TessBaseAPI>()) {
  namespace fs = std::filesystem;
  const std::string dir = tessdata_dir.empty() ? default_tessdata_dir() : tessdata_dir;
  if (language.empty()) throw StartupError("text reader: empty Tesseract language");
  std::stringstream languages(language);
  for (std::string lang; std::getline(languages, lang, '+');) {
    const fs::path data = fs::path(dir) / (lang + ".traineddata");
    if (!fs::is_regular_file(data))
      throw StartupError("text reader: Tesseract data " + data.string() +
                         " not found (install tesseract-ocr-" + lang + " or set tessdata_dir)");
  }
  // Silences Tesseract's per-image chatter ("Estimating resolution ...") on stderr.
  api_->SetVariable("debug_file", "/dev/null");
  if (api_->Init(dir.c_str(), language.c_str(), tesseract::OEM_LSTM_ONLY) != 0)
    throw StartupError("text reader: Tesseract cannot load language '" + language + "' from " +
                       dir + " (corrupt traineddata?)");
  api_->SetVariable("debug_file", "/dev/null");
  // Keyframes carry no resolution; a fixed one avoids Tesseract's guess and its warning.
  api_->SetVariable("user_defined_dpi", "300");
  if (thresholding_method < 0 || thresholding_method > 2)
    throw StartupError("text reader: thresholding_method " + std::to_string(thresholding_method) +
                       " is not 0 (Otsu), 1 (tiled Otsu) or 2 (Sauvola)");
  api_->SetVariable("thresholding_method", std::to_string(thresholding_method).c_str());
}

TesseractOcr::~TesseractOcr() {
  if (api_) api_->End();
}

std::vector<ReadWord> TesseractOcr::words(const cv::Mat& grey, Layout layout) {
  std::vector<ReadWord> out;
  if (grey.empty() || grey.type() != CV_8UC1 || grey.cols < 3 || grey.rows < 3) return out;
  const cv::Mat image = grey.isContinuous() ? grey : grey.clone();
  api_->SetPageSegMode(page_mode(layout));
  api_->SetImage(image.data, image.cols, image.rows, 1, int(image.step));
  if (api_->Recognize(nullptr) != 0) {
    api_->Clear();
    return out;
  }
  std::unique_ptr<tesseract::ResultIterator> it(api_->GetIterator());
  if (it) {
    do {
      const std::unique_ptr<char[]> text(it->GetUTF8Text(tesseract::RIL_WORD));
      if (!text) continue;
      int left = 0, top = 0, right = 0, bottom = 0;
      if (!it->BoundingBox(tesseract::RIL_WORD, &left, &top, &right, &bottom)) continue;
      ReadWord word;
      word.text = text.get();
      word.confidence = it->Confidence(tesseract::RIL_WORD) / 100.0f;
      word.box = cv::Rect(left, top, right - left, bottom - top);
      out.push_back(std::move(word));
    } while (it->Next(tesseract::RIL_WORD));
  }
  api_->Clear();
  return out;
}

}  // namespace keyfleet::station
