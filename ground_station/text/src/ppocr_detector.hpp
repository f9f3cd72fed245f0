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
  // kNow: built and checked with one forward pass here. kOnFirstUse: here the file is only
  // parsed and its map's shape checked (a corrupt file or one converted for another size still
  // fails at start-up); the network is built, with its first pass and OpenCV's buffers, by the
  // first detect(): a detector few images need (1280x736 beside keyframes) costs no start-up.
  enum class Build { kNow, kOnFirstUse };

  // Loads the converted model at `model_path`, built for `input_size` (multiples of 32), with
  // keyfleet's stand-in layers `layers` (by default in float: OpenCV's map to float rounding).
  // Throws StartupError naming the file.
  PpocrDetector(const std::string& model_path, cv::Size input_size, const DbParams& params,
                const vision::DnnLayers& layers = vision::DnnLayers::in_float(),
                Build build = Build::kNow);

  // Text lines in `image` (8-bit, 1, 3 or 4 channels), top-to-bottom then left-to-right.
  // An empty, unusable or absurd image gives no lines. Throws (StartupError naming the file)
  // only where a detector built on first use cannot be built then.
  std::vector<DetectedText> detect(const cv::Mat& image);

  cv::Size input_size() const { return input_size_; }
  bool built() const { return !net_.empty(); }

 private:
  void build();  // import under the stand-ins' scope and the probing pass
  cv::Mat probability_map(const cv::Mat& blob);

  std::string model_path_;
  vision::DnnLayers layers_;
  cv::Mat resized_, input_;  // the letterboxed image and the network's input, kept between calls
  cv::dnn::Net net_;
  cv::Size input_size_;
  DbParams params_;
};

namespace ppocr {

// `image` as 8-bit BGR (grey and BGRA converted); empty when it is not 8-bit 1/3/4 channels.
cv::Mat to_bgr8(const cv::Mat& image);

// The detector's input: `bgr` (8-bit BGR, at most `input_size`) normalised as PaddleOCR trained
// it, its channels as planes of a 1x3xHxW float `blob` (made or reused), padded bottom and
// right with 0 (the data set's mean, which the network sees as nothing). One pass, no
// temporaries: the blob OpenCV's convertTo, subtract, divide and blobFromImage gave.
void fill_input_planes(const cv::Mat& bgr, cv::Size input_size, cv::Mat& blob);

}  // namespace ppocr
}  // namespace keyfleet::station
