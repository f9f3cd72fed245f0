#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "line_reading.hpp"
#include "readers.hpp"

namespace keyfleet::station {
namespace {

// The recogniser's input widths (converted files ppocr_rec_w<W>.onnx): a line goes to the
// narrowest that holds it at height 48. 160 is enough for most words and costs half of 320.
constexpr int kRecogniserWidths[] = {160, 320, 640};

cv::Size detector_size(const std::string& text) {
  int width = 0, height = 0;
  char end = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &width, &height, &end) != 2 || width <= 0 ||
      height <= 0 || width % 32 != 0 || height % 32 != 0)
    throw StartupError("text reader: ppocr_detector_size '" + text +
                       "' is not WxH with sides multiples of 32");
  return {width, height};
}

// A converted file of the ppocr folder, found like every model; the message says how to get it.
std::string locate(const TextReadingConfig& params, const std::string& file,
                   const std::string& what) {
  try {
    return vision::locate_model(params.ppocr_models + "/" + file, what);
  } catch (const StartupError& e) {
    throw StartupError(std::string(e.what()) +
                       "; scripts/fetch_ppocr.sh downloads and converts the ppocr models");
  }
}

DbParams db_params(const TextReadingConfig& params) {
  for (const double v : {params.ppocr_binary_threshold, params.ppocr_box_threshold})
    if (!(v >= 0 && v <= 1))
      throw StartupError("text reader: ppocr thresholds must be within 0..1");
  if (!(params.ppocr_unclip_ratio >= 0 && params.ppocr_unclip_ratio <= 10))
    throw StartupError("text reader: ppocr_unclip_ratio must be within 0..10");
  DbParams db;
  db.binary_threshold = float(params.ppocr_binary_threshold);
  db.box_threshold = float(params.ppocr_box_threshold);
  db.unclip_ratio = float(params.ppocr_unclip_ratio);
  return db;
}

PpocrDetector make_detector(const TextReadingConfig& params) {
  const cv::Size size = detector_size(params.ppocr_detector_size);
  const std::string file = "ppocr_det_" + params.ppocr_detector_size + ".onnx";
  return PpocrDetector(locate(params, file, "ppocr detector"), size, db_params(params));
}

PpocrRecognizer make_recognizer(const TextReadingConfig& params) {
  std::map<int, std::string> files;
  for (const int width : kRecogniserWidths)
    files[width] =
        locate(params, "ppocr_rec_w" + std::to_string(width) + ".onnx", "ppocr recogniser");
  if (!(params.ppocr_space_probability >= 0 && params.ppocr_space_probability <= 1))
    throw StartupError("text reader: ppocr_space_probability must be within 0..1");
  return PpocrRecognizer(files, locate(params, "ppocr_keys_v1.txt", "ppocr character list"),
                         {params.ppocr_latin_only, float(params.ppocr_space_probability)});
}

float quad_area(const TextQuad& quad) {
  return float(std::abs(cv::contourArea(std::vector<cv::Point2f>(quad.begin(), quad.end()))));
}

// The detector of the mosaics of hinted regions (ppocr_region_hints.cpp); null for "off".
std::unique_ptr<PpocrDetector> make_hint_detector(const TextReadingConfig& params) {
  if (params.region_hints == "off") return nullptr;
  if (params.region_hints != "only" && params.region_hints != "first")
    throw StartupError("text reader: region_hints '" + params.region_hints +
                       "' is not off, only or first");
  const std::string file = "ppocr_det_" + params.region_hint_detector_size + ".onnx";
  return std::make_unique<PpocrDetector>(locate(params, file, "ppocr region-hint detector"),
                                         detector_size(params.region_hint_detector_size),
                                         db_params(params));
}

}  // namespace

PpocrReader::PpocrReader(const TextReadingConfig& params)
    : params_(params),
      detector_(make_detector(params)),
      recognizer_(make_recognizer(params)),
      hint_detector_(make_hint_detector(params)) {
  // Process-wide, as for mininet+tesseract's segmenter: the station's CPU budget for OpenCV DNN.
  if (params.threads > 0) cv::setNumThreads(params.threads);
}

std::vector<ReadWord> PpocrReader::read(const cv::Mat& bgr) {
  const cv::Mat image = ppocr::to_bgr8(bgr);
  if (image.empty() || image.cols < 2 || image.rows < 2) return {};
  std::vector<TextQuad> lines;
  if (std::max(image.cols, image.rows) < kMaxCropLongSide) {
    // A word or line crop: the detector, trained on scenes, would only cut into it.
    const float w = float(image.cols), h = float(image.rows);
    lines.push_back({cv::Point2f(0, 0), cv::Point2f(w, 0), cv::Point2f(w, h), cv::Point2f(0, h)});
  } else {
    for (const auto& text : detector_.detect(image)) lines.push_back(text.quad);
  }
  return read_lines(image, std::move(lines));
}

std::vector<ReadWord> PpocrReader::read_lines(const cv::Mat& image, std::vector<TextQuad> lines) {
  if (int(lines.size()) > params_.max_regions) {
    std::stable_sort(lines.begin(), lines.end(), [](const TextQuad& a, const TextQuad& b) {
      return quad_area(a) > quad_area(b);
    });
    lines.resize(std::size_t(params_.max_regions));
  }
  const cv::Rect frame(0, 0, image.cols, image.rows);
  std::vector<ReadWord> words;
  for (const auto& quad : lines) {
    const auto line = recognizer_.recognize(image, quad);
    if (!line) continue;
    for (const auto& word : line->words) {
      const std::vector<cv::Point2f> corners(word.quad.begin(), word.quad.end());
      ReadWord read{word.text, word.confidence, cv::boundingRect(corners) & frame, word.quad};
      if (keep_word(read, params_)) words.push_back(std::move(read));
    }
  }
  return words;
}

}  // namespace keyfleet::station
