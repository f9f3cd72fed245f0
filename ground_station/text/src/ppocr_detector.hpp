#pragma once
// PP-OCRv4 text detector (DB, differentiable binarisation) run through OpenCV DNN.
//
// OpenCV 4.6 computes blob shapes once, so models/ppocr/convert_ppocr.py writes one file per
// input size (ppocr_det_<W>x<H>.onnx) and each image is letterboxed into that size (aspect kept,
// padded bottom/right); the boxes come from vision/db_boxes.hpp, in the input image's pixels.
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "keyfleet/vision/db_boxes.hpp"
#include "keyfleet/vision/dnn_layers.hpp"

#include <string>
#include <vector>

namespace keyfleet::station {

using vision::DbParams;
using vision::DetectedText;
using vision::TextQuad;

class PpocrDetector {
 public:
  // Loads the converted model at `model_path`, built for `input_size` (multiples of 32) and
  // checks it with one forward pass, with keyfleet's stand-in layers `layers` (by default in
  // float: OpenCV's map to float rounding). Throws StartupError naming the file.
  PpocrDetector(const std::string& model_path, cv::Size input_size, const DbParams& params,
                const vision::DnnLayers& layers = vision::DnnLayers::in_float());

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

// `image` as 8-bit BGR (grey and BGRA converted); empty when it is not 8-bit 1/3/4 channels.
cv::Mat to_bgr8(const cv::Mat& image);

}  // namespace ppocr
}  // namespace keyfleet::station
