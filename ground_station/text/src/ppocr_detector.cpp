#include "ppocr_detector.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::station {
namespace {

// PaddleOCR normalises with the ImageNet numbers (published in RGB order) applied to the
// channels in the order OpenCV decoded them, so 0.485 goes to blue. The model was trained so.
constexpr float kMean[3] = {0.485f, 0.456f, 0.406f};
constexpr float kStd[3] = {0.229f, 0.224f, 0.225f};

}  // namespace

namespace ppocr {

cv::Mat to_bgr8(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U) return {};
  cv::Mat bgr;
  switch (image.channels()) {
    case 3: return image;
    case 1: cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR); return bgr;
    case 4: cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR); return bgr;
    default: return {};
  }
}

}  // namespace ppocr

PpocrDetector::PpocrDetector(const std::string& model_path, cv::Size input_size,
                             const DbParams& params, const vision::DnnLayers& layers)
    : input_size_(input_size), params_(params) {
  if (input_size.width <= 0 || input_size.height <= 0 || input_size.width % 32 != 0 ||
      input_size.height % 32 != 0)
    throw StartupError("ppocr detector: input size " + std::to_string(input_size.width) + "x" +
                       std::to_string(input_size.height) + " is not a multiple of 32");
  // keyfleet's stand-ins for OpenCV's 1x1, dense 3x3 and depthwise convolutions (in float: the
  // same map to float rounding in about 0.7x the time). OpenCV creates the layers on import and
  // on the first pass (the probe below), so the scope covers both.
  const vision::DnnLayersScope stand_ins(layers);
  try {
    net_ = cv::dnn::readNetFromONNX(model_path);
  } catch (const cv::Exception& e) {
    throw StartupError("ppocr detector: cannot load '" + model_path + "': " + e.what());
  }
  if (net_.empty()) throw StartupError("ppocr detector: '" + model_path + "' holds no network");
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  // One pass on a blank input: a file converted for another size fails here, not per image.
  const int shape[] = {1, 3, input_size.height, input_size.width};
  if (probability_map(cv::Mat(4, shape, CV_32F, cv::Scalar(0))).empty())
    throw StartupError("ppocr detector: '" + model_path + "' does not give a " +
                       std::to_string(input_size.width) + "x" + std::to_string(input_size.height) +
                       " probability map");
}

cv::Mat PpocrDetector::probability_map(const cv::Mat& blob) {
  try {
    net_.setInput(blob);
    cv::Mat out = net_.forward();
    if (out.dims != 4 || out.size[2] != input_size_.height || out.size[3] != input_size_.width)
      return {};
    return cv::Mat(input_size_, CV_32F, out.ptr<float>()).clone();
  } catch (const cv::Exception&) {
    return {};
  }
}

std::vector<DetectedText> PpocrDetector::detect(const cv::Mat& image) {
  const cv::Mat bgr = ppocr::to_bgr8(image);
  if (bgr.empty()) return {};
  const float scale = std::min(float(input_size_.width) / float(bgr.cols),
                               float(input_size_.height) / float(bgr.rows));
  const cv::Size fitted(std::clamp(cvRound(float(bgr.cols) * scale), 1, input_size_.width),
                        std::clamp(cvRound(float(bgr.rows) * scale), 1, input_size_.height));
  try {
    cv::Mat resized, normalised;
    cv::resize(bgr, resized, fitted, 0, 0, cv::INTER_LINEAR);
    resized.convertTo(normalised, CV_32FC3, 1.0 / 255.0);
    normalised -= cv::Scalar(kMean[0], kMean[1], kMean[2]);
    cv::divide(normalised, cv::Scalar(kStd[0], kStd[1], kStd[2]), normalised);
    // Padded with 0 after normalising (the data set's mean), which the network sees as nothing.
    cv::Mat padded(input_size_, CV_32FC3, cv::Scalar::all(0));
    normalised.copyTo(padded(cv::Rect(cv::Point(0, 0), fitted)));
    const cv::Mat prob = probability_map(cv::dnn::blobFromImage(padded));
    if (prob.empty()) return {};
    return vision::db_postprocess(prob, fitted, scale, bgr.size(), params_);
  } catch (const cv::Exception&) {
    return {};
  }
}

}  // namespace keyfleet::station
