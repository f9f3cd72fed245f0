#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/text_segmenter.hpp"
#include "line_reading.hpp"
#include "readers.hpp"

namespace keyfleet::station {
namespace {

// The recogniser's input widths (converted files ppocr_rec[_latin]_w<W>.onnx): a line goes to the
// narrowest that holds it at height 48, and its time is about linear in that width. Every 32
// columns up to 256 (half of a fleet's lines fit 128):
// docs/results/2026-11-29-recogniser-widths.md.
constexpr int kRecogniserWidths[] = {96, 128, 160, 192, 224, 256, 320, 640};

// The detector sizes scripts/fetch_ppocr.sh converts, which "auto" chooses among: a keyframe's
// own 4:3 size and one holding 16:9 photos of 1280x720 unscaled.
constexpr const char* kFetchedDetectorSizes[] = {"640x480", "1280x736"};
const cv::Size kKeyframeSize(640, 480);

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
    return vision::locate_model(params.ppocr.models + "/" + file, what);
  } catch (const StartupError& e) {
    throw EngineModelsMissing(std::string(e.what()) +
                              "; scripts/fetch_ppocr.sh downloads and converts the ppocr models");
  }
}

// keyfleet's stand-in layers for both networks: float, or the wide 1x1 convolutions in int8.
vision::DnnLayers stand_in_layers(const TextReadingConfig& params) {
  vision::DnnLayers layers = vision::DnnLayers::in_float();
  layers.int8_pointwise = params.ppocr.int8;
  return layers;
}

DbParams db_params(const TextReadingConfig& params) {
  for (const double v : {params.ppocr.binary_threshold, params.ppocr.box_threshold})
    if (!(v >= 0 && v <= 1))
      throw StartupError("text reader: ppocr thresholds must be within 0..1");
  if (!(params.ppocr.unclip_ratio >= 0 && params.ppocr.unclip_ratio <= 10))
    throw StartupError("text reader: ppocr_unclip_ratio must be within 0..10");
  DbParams db;
  db.binary_threshold = float(params.ppocr.binary_threshold);
  db.box_threshold = float(params.ppocr.box_threshold);
  db.unclip_ratio = float(params.ppocr.unclip_ratio);
  return db;
}

// ppocr_keyframe_detector: a converted detector tuned to a smaller input than a keyframe's, its
// size from the .json beside it (as the agent's semantic model), for the images "auto" would
// give the fetched 640x480 file.
SizedPpocrDetector make_keyframe_detector(const TextReadingConfig& params) {
  const std::string what = "ppocr keyframe detector (analysis.text.ppocr_keyframe_detector)";
  const std::string path = vision::locate_model(params.ppocr.keyframe_detector, what);
  const cv::Size input = vision::read_segmenter_info(path).input_size;
  if (input.width > kKeyframeSize.width || input.height > kKeyframeSize.height ||
      input.width % 32 || input.height % 32)
    throw StartupError(what + ": " + path + " takes " + std::to_string(input.width) + "x" +
                       std::to_string(input.height) +
                       ", not sides multiples of 32 within a keyframe's 640x480");
  return {PpocrDetector(path, input, db_params(params), stand_in_layers(params)), kKeyframeSize};
}

std::vector<SizedPpocrDetector> make_detectors(const TextReadingConfig& params) {
  const bool automatic = params.ppocr.detector_size == "auto";
  if (!automatic && !params.ppocr.keyframe_detector.empty())
    throw StartupError("text reader: ppocr_keyframe_detector '" + params.ppocr.keyframe_detector +
                       "' stands in for the fetched 640x480 file under ppocr_detector_size auto, "
                       "but the size is '" +
                       params.ppocr.detector_size + "'");
  std::vector<std::string> sizes = {params.ppocr.detector_size};
  if (automatic) sizes.assign(std::begin(kFetchedDetectorSizes), std::end(kFetchedDetectorSizes));
  std::vector<SizedPpocrDetector> detectors;
  for (const auto& size : sizes) {
    const cv::Size input = detector_size(size);
    if (input == kKeyframeSize && !params.ppocr.keyframe_detector.empty()) {  // "auto" (above)
      detectors.push_back(make_keyframe_detector(params));
      continue;
    }
    // Under "auto" the detector for photos larger than a keyframe is built by the first such
    // photo: a station of keyframes does not spend 0.6 s of CPU starting it.
    const auto build = automatic && input != kKeyframeSize ? PpocrDetector::Build::kOnFirstUse
                                                           : PpocrDetector::Build::kNow;
    detectors.push_back(
        {PpocrDetector(locate(params, "ppocr_det_" + size + ".onnx", "ppocr detector"), input,
                       db_params(params), stand_in_layers(params), build),
         input});
  }
  std::sort(detectors.begin(), detectors.end(),
            [](const auto& a, const auto& b) { return a.holds.area() < b.holds.area(); });
  return detectors;
}

// Latin only: the files whose classifier the converter cut to the Latin classes (its last layer
// 1/50 of the work, the softmax over 124 classes instead of 6,625); else PP-OCRv4's whole list.
PpocrRecognizer make_recognizer(const TextReadingConfig& params) {
  const bool latin = params.ppocr.latin_only;
  const std::string prefix = latin ? "ppocr_rec_latin_w" : "ppocr_rec_w";
  std::map<int, std::string> files;
  for (const int width : kRecogniserWidths)
    files[width] = locate(params, prefix + std::to_string(width) + ".onnx", "ppocr recogniser");
  if (!(params.ppocr.space_probability >= 0 && params.ppocr.space_probability <= 1))
    throw StartupError("text reader: ppocr_space_probability must be within 0..1");
  return PpocrRecognizer(
      files,
      locate(params, latin ? "ppocr_keys_latin.txt" : "ppocr_keys_v1.txt", "ppocr character list"),
      {latin, float(params.ppocr.space_probability), stand_in_layers(params)});
}

float quad_area(const TextQuad& quad) {
  return float(std::abs(cv::contourArea(std::vector<cv::Point2f>(quad.begin(), quad.end()))));
}

// The detector of the mosaics of hinted regions (ppocr_region_hints.cpp); null for "off".
std::unique_ptr<PpocrDetector> make_hint_detector(const TextReadingConfig& params) {
  if (params.ppocr.region_hints == "off") return nullptr;
  if (params.ppocr.region_hints != "only" && params.ppocr.region_hints != "first")
    throw StartupError("text reader: region_hints '" + params.ppocr.region_hints +
                       "' is not off, only or first");
  const std::string file = "ppocr_det_" + params.ppocr.region_hint_detector_size + ".onnx";
  std::string path;
  try {
    path = locate(params, file, "ppocr region-hint detector");
  } catch (const EngineModelsMissing& e) {
    // The detectors above were found: a size the fetch does not convert is the setting's error,
    // not a missing install, so the station's fallback engine does not stand in for it.
    throw StartupError(std::string(e.what()) + " (analysis.text.region_hint_detector_size)");
  }
  return std::make_unique<PpocrDetector>(path,
                                         detector_size(params.ppocr.region_hint_detector_size),
                                         db_params(params), stand_in_layers(params));
}

}  // namespace

PpocrReader::PpocrReader(const TextReadingConfig& params)
    : params_(params),
      detectors_(make_detectors(params)),
      recognizer_(make_recognizer(params)),
      hint_detector_(make_hint_detector(params)) {
  // Process-wide, as for mininet+tesseract's segmenter: the station's CPU budget for OpenCV DNN.
  if (params.threads > 0) cv::setNumThreads(params.threads);
}

PpocrDetector& PpocrReader::detector_for(cv::Size image) {
  for (auto& sized : detectors_)
    if (sized.holds.width >= image.width && sized.holds.height >= image.height)
      return sized.detector;
  return detectors_.back().detector;
}

std::vector<ReadWord> PpocrReader::read(const cv::Mat& bgr) {
  const cv::Mat image = ppocr::to_bgr8(bgr);
  if (image.empty() || image.cols < 2 || image.rows < 2) return {};
  std::vector<TextQuad> lines;
  const bool crop = std::max(image.cols, image.rows) < kMaxCropLongSide;
  if (crop) {
    // A word or line crop: the detector, trained on scenes, would only cut into it.
    const float w = float(image.cols), h = float(image.rows);
    lines.push_back({cv::Point2f(0, 0), cv::Point2f(w, 0), cv::Point2f(w, h), cv::Point2f(0, h)});
  } else {
    for (const auto& text : detector_for(image.size()).detect(image)) lines.push_back(text.quad);
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
  const bool crop = std::max(image.cols, image.rows) < kMaxCropLongSide;
  const int margin = crop ? -1 : params_.ppocr.cut_word_margin;
  std::vector<ReadWord> words;
  for (const auto& quad : lines) {
    // A line the frame cuts: its first or last word (or all, cut above or below) is a fragment
    // even where the characters read stop short of the edge.
    const cv::Rect line_box =
        cv::boundingRect(std::vector<cv::Point2f>(quad.begin(), quad.end())) & frame;
    const bool cut_across =
        margin >= 0 && (line_box.y <= margin || line_box.br().y >= frame.height - margin);
    // Not recognised where no word of it could be kept: all cut, or all lower than
    // min_word_height (a word's box lies within its line's, give or take a pixel of rounding).
    if (cut_across || line_box.height + 1 < params_.min_word_height) continue;
    const auto line = recognizer_.recognize(image, quad);
    if (!line) continue;
    const bool cut_left = margin >= 0 && line_box.x <= margin;
    const bool cut_right = margin >= 0 && line_box.br().x >= frame.width - margin;
    for (std::size_t i = 0; i < line->words.size(); ++i) {
      const auto& word = line->words[i];
      const std::vector<cv::Point2f> corners(word.quad.begin(), word.quad.end());
      ReadWord read{word.text, word.confidence, cv::boundingRect(corners) & frame, word.quad};
      const bool cut = cut_across || (i == 0 && cut_left) ||
                       (i + 1 == line->words.size() && cut_right) ||
                       cut_by_frame(read.box, frame.size(), margin);
      if (!cut && keep_word(read, params_)) words.push_back(std::move(read));
    }
  }
  return words;
}

}  // namespace keyfleet::station
