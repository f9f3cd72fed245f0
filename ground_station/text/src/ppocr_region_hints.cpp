// PpocrReader with the robot's text regions: the DB detector runs on mosaics of the hinted
// regions instead of the whole image. The converted detectors take one input size each, so a
// crop alone would cost a whole pass; packed together, the regions of a keyframe usually fit in
// one pass of a smaller detector, at the scale the whole image would have had in the main one.
#include <opencv2/imgproc.hpp>

#include <algorithm>

#include "line_reading.hpp"
#include "readers.hpp"

namespace keyfleet::station {
namespace ppocr {
namespace {

// Unites overlapping rectangles until none overlap.
void unite_overlapping(std::vector<cv::Rect>& rects) {
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < rects.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < rects.size() && !merged; ++j)
        if ((rects[i] & rects[j]).area() > 0) {
          rects[i] |= rects[j];
          rects.erase(rects.begin() + long(j));
          merged = true;
        }
  }
}

}  // namespace

std::vector<std::vector<MosaicPlacement>> pack_hints(const std::vector<cv::Rect>& hints,
                                                     cv::Size image_size, double padding,
                                                     cv::Size mosaic, int gap,
                                                     std::size_t max_mosaics) {
  const cv::Rect image(cv::Point(0, 0), image_size);
  std::vector<cv::Rect> crops;
  for (const cv::Rect& h : hints) {
    const int pad = std::max(4, int(padding * h.height + 0.5));
    const cv::Rect padded = cv::Rect(h.x - pad, h.y - pad, h.width + 2 * pad, h.height + 2 * pad);
    if ((padded & image).area() > 0) crops.push_back(padded & image);
  }
  unite_overlapping(crops);
  std::stable_sort(crops.begin(), crops.end(),
                   [](const cv::Rect& a, const cv::Rect& b) { return a.height > b.height; });
  // Rows ("shelves") left to right, top to bottom; a new mosaic when the rows are full.
  std::vector<std::vector<MosaicPlacement>> mosaics;
  int x = 0, y = 0, row_height = 0;
  for (const cv::Rect& crop : crops) {
    if (crop.width > mosaic.width || crop.height > mosaic.height) return {};
    if (mosaics.empty() || x + crop.width > mosaic.width) {  // next row
      y += row_height + gap, x = 0, row_height = 0;
      if (mosaics.empty() || y + crop.height > mosaic.height) {
        if (mosaics.size() == max_mosaics) return {};
        mosaics.emplace_back();
        y = 0;
      }
    }
    mosaics.back().push_back({crop, cv::Point(x, y)});
    x += crop.width + gap;
    row_height = std::max(row_height, crop.height);
  }
  return mosaics;
}

std::optional<TextQuad> quad_in_image(const TextQuad& in_mosaic,
                                      const std::vector<MosaicPlacement>& placements) {
  cv::Point2f centre(0, 0);
  for (const auto& p : in_mosaic) centre += p * 0.25f;
  for (const MosaicPlacement& m : placements) {
    const cv::Rect2f placed(cv::Point2f(m.at), cv::Size2f(m.source.size()));
    if (!placed.contains(centre)) continue;
    TextQuad out;
    const cv::Point2f shift(float(m.source.x - m.at.x), float(m.source.y - m.at.y));
    for (std::size_t i = 0; i < out.size(); ++i) {
      const cv::Point2f p = in_mosaic[i] + shift;
      out[i] = {std::clamp(p.x, float(m.source.x), float(m.source.br().x - 1)),
                std::clamp(p.y, float(m.source.y), float(m.source.br().y - 1))};
    }
    return out;
  }
  return std::nullopt;
}

}  // namespace ppocr

std::vector<ReadWord> PpocrReader::read_with_hints(const cv::Mat& bgr,
                                                   const std::vector<cv::Rect>& hints) {
  const cv::Mat image = ppocr::to_bgr8(bgr);
  if (!hint_detector_ || hints.empty() || image.empty() ||
      std::max(image.cols, image.rows) < kMaxCropLongSide)
    return read(bgr);
  // The mosaic is sized so that the hint detector scales it as the main detector would scale
  // the whole image; it pays while its passes cost less than the whole image's.
  const cv::Size main = detector_for(image.size()).input_size();
  const cv::Size small = hint_detector_->input_size();
  const double scale = std::min(double(main.width) / image.cols, double(main.height) / image.rows);
  const cv::Size mosaic(int(small.width / scale), int(small.height / scale));
  const std::size_t max_mosaics =
      std::max<std::size_t>(1, std::size_t(main.area() / std::max(1, small.area())));
  const auto mosaics =
      ppocr::pack_hints(hints, image.size(), params_.ppocr.region_hint_padding, mosaic, 8,
                        main.area() > small.area() ? max_mosaics - 1 : 1);
  if (mosaics.empty()) return read(bgr);

  std::vector<TextQuad> lines;
  for (const auto& placements : mosaics) {
    // Filled with the detector's mean colour, which it sees as nothing.
    cv::Mat canvas(mosaic, CV_8UC3, cv::Scalar(0.485 * 255, 0.456 * 255, 0.406 * 255));
    for (const auto& m : placements)
      image(m.source).copyTo(canvas(cv::Rect(m.at, m.source.size())));
    for (const DetectedText& found : hint_detector_->detect(canvas))
      if (const auto quad = ppocr::quad_in_image(found.quad, placements)) lines.push_back(*quad);
  }
  std::vector<ReadWord> words = read_lines(image, std::move(lines));
  if (words.empty() && params_.ppocr.region_hints == "first") return read(bgr);
  return words;
}

}  // namespace keyfleet::station
