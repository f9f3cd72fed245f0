#pragma once
// PP-OCRv4 text detector (DB, differentiable binarisation) run through OpenCV DNN.
//
// OpenCV 4.6 computes blob shapes once, so models/ppocr/convert_ppocr.py writes one file per
// input size (ppocr_det_<W>x<H>.onnx) and each image is letterboxed into that size (aspect kept,
// padded bottom/right). The post-processing follows PaddleOCR's DBPostProcess: threshold ->
// contours -> minimum-area boxes -> mean probability inside the box -> unclip (polygon offset) ->
// quadrilaterals in the input image's pixels.
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include <array>
#include <string>
#include <vector>

namespace keyfleet::station {

// Four corners in reading order: top-left, top-right, bottom-right, bottom-left.
using TextQuad = std::array<cv::Point2f, 4>;

struct DetectedText {
  TextQuad quad;
  float score = 0;  // mean text probability inside the box before unclipping
};

struct DbParams {
  float binary_threshold = 0.3f;  // probability above which a map pixel is text
  float box_threshold = 0.6f;     // boxes with a lower mean probability are dropped
  float unclip_ratio = 1.5f;      // DB trains on shrunk text; boxes are grown back by this
  float min_size = 3;             // boxes with a shorter side (map pixels) are dropped
  int max_candidates = 1000;      // contours examined at most
};

class PpocrDetector {
 public:
  // Loads the converted model at `model_path`, built for `input_size` (multiples of 32) and
  // checks it with one forward pass. Throws StartupError naming the file.
  PpocrDetector(const std::string& model_path, cv::Size input_size, const DbParams& params);

  // Text lines in `image` (8-bit, 1, 3 or 4 channels), top-to-bottom then left-to-right.
  // Never throws: an empty, unusable or absurd image gives no lines.
  std::vector<DetectedText> detect(const cv::Mat& image);

  cv::Size input_size() const { return input_size_; }

 private:
  cv::Mat probability_map(const cv::Mat& blob);

  cv::dnn::Net net_;
  cv::Size input_size_;
  DbParams params_;
};

namespace ppocr {

// DB post-processing of a probability map (CV_32F). Only the top-left `valid` part of the map
// holds the image (the rest is letterbox padding); `scale` maps image to map pixels.
std::vector<DetectedText> db_postprocess(const cv::Mat& prob, cv::Size valid, float scale,
                                         cv::Size image_size, const DbParams& params);

// Corners of a rotated rectangle in TextQuad's order.
TextQuad ordered_corners(const cv::RotatedRect& rect);

// Minkowski sum of a convex polygon and a disc of radius `distance` (what Clipper's round-join
// offset computes, which PaddleOCR uses), arcs sampled with `arc_steps` segments.
std::vector<cv::Point2f> offset_convex_polygon(const std::vector<cv::Point2f>& polygon,
                                               float distance, int arc_steps = 8);

// PaddleOCR's unclip: the box offset by area * ratio / perimeter, as a minimum-area rectangle.
cv::RotatedRect unclip(const TextQuad& box, float ratio);

// `image` as 8-bit BGR (grey and BGRA converted); empty when it is not 8-bit 1/3/4 channels.
cv::Mat to_bgr8(const cv::Mat& image);

}  // namespace ppocr
}  // namespace keyfleet::station
