#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "image_prep.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/image_helpers.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "line_reading.hpp"
#include "readers.hpp"

namespace keyfleet::station {
namespace {

int round_up_64(double v) { return std::max(64, int(std::ceil(v / 64.0)) * 64); }

// Joins boxes that overlap (after padding, pieces of one line overlap) until none do.
std::vector<cv::Rect> merge_overlapping(std::vector<cv::Rect> boxes) {
  bool merged = true;
  while (merged) {
    merged = false;
    for (std::size_t i = 0; i < boxes.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < boxes.size() && !merged; ++j)
        if ((boxes[i] & boxes[j]).area() > 0) {
          boxes[i] |= boxes[j];
          boxes.erase(boxes.begin() + long(j));
          merged = true;
        }
  }
  return boxes;
}

}  // namespace

DetectRecogniseReader::DetectRecogniseReader(const TextReadingConfig& params)
    : params_(params),
      model_path_(vision::locate_model(params.mininet.segmenter_model, "segmenter model")),
      ocr_(params.tesseract.tessdata_dir, params.tesseract.language,
           params.tesseract.thresholding_method) {
  if (params.mininet.segmenter_widths.empty())
    throw StartupError("text reader: no segmenter widths for mininet+tesseract");
  for (int w : params.mininet.segmenter_widths)
    if (w < 64 || w % 64 != 0)
      throw StartupError("text reader: segmenter width " + std::to_string(w) +
                         " is not a positive multiple of 64");
  // Loads and checks the model now (16:9, the ICDAR photos' shape) so a bad one fails here.
  for (int w : params.mininet.segmenter_widths) segmenter_for(w, cv::Size(16, 9));
}

vision::DnnTextSegmenter& DetectRecogniseReader::segmenter_for(int w, cv::Size image_size) {
  const int h = round_up_64(double(w) * image_size.height / std::max(1, image_size.width));
  auto& slot = segmenters_[{w, h}];
  if (!slot)
    slot = std::make_unique<vision::DnnTextSegmenter>(model_path_, params_.threads, cv::Size(w, h));
  return *slot;
}

std::vector<cv::Rect> DetectRecogniseReader::regions(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3 || bgr.cols < 8 || bgr.rows < 8) return {};
  std::vector<cv::Rect> boxes;
  for (int w : params_.mininet.segmenter_widths) {
    auto at = regions_at(w, bgr);
    boxes.insert(boxes.end(), at.begin(), at.end());
  }
  boxes = merge_overlapping(std::move(boxes));
  std::sort(boxes.begin(), boxes.end(),
            [](const cv::Rect& a, const cv::Rect& b) { return a.area() > b.area(); });
  if (int(boxes.size()) > params_.max_regions) boxes.resize(std::size_t(params_.max_regions));
  return boxes;
}

std::vector<cv::Rect> DetectRecogniseReader::regions_at(int width, const cv::Mat& bgr) {
  cv::Mat mask;
  try {
    mask = segmenter_for(width, bgr.size()).segment({bgr}).at(0);
  } catch (const std::exception&) {
    return {};  // a per-keyframe path: no regions rather than an exception
  }
  // Close small gaps between letters along a line before taking components.
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 3)));
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  const double sx = double(bgr.cols) / mask.cols, sy = double(bgr.rows) / mask.rows;
  const cv::Rect bounds(0, 0, bgr.cols, bgr.rows);
  std::vector<cv::Rect> boxes;
  for (int i = 1; i < n; ++i) {
    if (stats.at<int>(i, cv::CC_STAT_AREA) < 12) continue;  // speckle
    const cv::Rect m(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                     stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
    const int x = int(m.x * sx), y = int(m.y * sy);
    const int w = int(std::ceil(m.width * sx)), h = int(std::ceil(m.height * sy));
    const int pad = int(std::ceil(float(params_.mininet.region_padding) * h)) + 2;
    boxes.push_back(cv::Rect(x - pad, y - pad, w + 2 * pad, h + 2 * pad) & bounds);
  }
  return boxes;
}

std::vector<ReadWord> DetectRecogniseReader::read(const cv::Mat& image) {
  const cv::Mat grey = vision::to_grey(image, 8);
  if (grey.empty()) return {};
  cv::Mat bgr;
  if (image.channels() == 3) {
    bgr = image;
  } else {
    cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  }
  std::vector<ReadWord> kept;
  const cv::Rect bounds(0, 0, grey.cols, grey.rows);
  // A crop of one word has no scene for the detector to search.
  const bool crop = std::max(grey.cols, grey.rows) < kMaxCropLongSide;
  const std::vector<cv::Rect> boxes = crop ? std::vector<cv::Rect>{bounds} : regions(bgr);
  for (const cv::Rect& box : boxes) {
    // Tall regions hold several lines: read them as sparse text at the whole image's scale.
    std::vector<ReadWord> words;
    if (crop || box.height * 2 < box.width) {
      words = read_line(ocr_, grey, box, params_.tesseract.line_height);
    } else {
      const double scale = reading_scale(grey.size(), params_.min_long_side, params_.max_long_side);
      words = ocr_.words(rescaled(grey(box), scale), TesseractOcr::Layout::kSparseText);
      map_back(words, scale, box.tl(), bounds);
    }
    for (auto& w : words)
      if (keep_word(w, params_)) kept.push_back(std::move(w));
  }
  return kept;
}

}  // namespace keyfleet::station
