#include "ppocr_detector.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/model_files.hpp"

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

void fill_input_planes(const cv::Mat& bgr, cv::Size input_size, cv::Mat& blob) {
  const int shape[] = {1, 3, input_size.height, input_size.width};
  if (blob.dims != 4 || blob.type() != CV_32F || blob.size[2] != input_size.height ||
      blob.size[3] != input_size.width)
    blob.create(4, shape, CV_32F);
  if (bgr.cols < input_size.width || bgr.rows < input_size.height) blob.setTo(0);
  // Each channel's 256 values as the arithmetic of convertTo (x 1/255 in float), subtracting the
  // mean in float and cv::divide by the deviation (in double) gives them: the blob those gave.
  static const auto table = [] {
    std::array<std::array<float, 256>, 3> t{};
    for (int c = 0; c < 3; ++c)
      for (int v = 0; v < 256; ++v)
        t[c][v] = float(double(float(v) * (1.0f / 255.0f) - kMean[c]) / double(kStd[c]));
    return t;
  }();
  const std::size_t plane = std::size_t(input_size.width) * std::size_t(input_size.height);
  float* planes[3];
  for (int c = 0; c < 3; ++c) planes[c] = blob.ptr<float>() + std::size_t(c) * plane;
  const int rows = std::min(bgr.rows, input_size.height),
            cols = std::min(bgr.cols, input_size.width);
  for (int y = 0; y < rows; ++y) {
    const std::uint8_t* in = bgr.ptr<std::uint8_t>(y);
    const std::size_t row = std::size_t(y) * std::size_t(input_size.width);
    for (int x = 0; x < cols; ++x)
      for (int c = 0; c < 3; ++c) planes[c][row + x] = table[c][in[3 * x + c]];
  }
}

}  // namespace ppocr

PpocrDetector::PpocrDetector(const std::string& model_path, cv::Size input_size,
                             const DbParams& params, const vision::DnnLayers& layers, Build build)
    : model_path_(model_path), layers_(layers), input_size_(input_size), params_(params) {
  if (input_size.width <= 0 || input_size.height <= 0 || input_size.width % 32 != 0 ||
      input_size.height % 32 != 0)
    throw StartupError("ppocr detector: input size " + std::to_string(input_size.width) + "x" +
                       std::to_string(input_size.height) + " is not a multiple of 32");
  if (build == Build::kNow) {
    this->build();
    return;
  }
  // Parsed with OpenCV's own layers (no stand-ins, no pass): the shapes say what the map is.
  const std::string size =
      std::to_string(input_size.width) + "x" + std::to_string(input_size.height);
  try {
    cv::dnn::Net net = vision::load_onnx_network(model_path, "ppocr detector");
    std::vector<int> ids;
    std::vector<std::vector<cv::dnn::MatShape>> in, out;
    net.getLayersShapes(cv::dnn::MatShape{1, 3, input_size.height, input_size.width}, ids, in, out);
    if (out.empty() || out.back().size() != 1 ||
        out.back()[0] != cv::dnn::MatShape{1, 1, input_size.height, input_size.width})
      throw StartupError("ppocr detector: '" + model_path + "' does not give a " + size +
                         " probability map");
  } catch (const cv::Exception& e) {
    throw StartupError("ppocr detector: cannot load '" + model_path + "' at " + size + ": " +
                       e.what());
  }
}

void PpocrDetector::build() {
  // keyfleet's stand-ins for OpenCV's 1x1, dense 3x3 and depthwise convolutions (in float: the
  // same map to float rounding in about 0.7x the time). OpenCV creates the layers on import and
  // on the first pass (the probe below), so the scope covers both.
  const vision::DnnLayersScope stand_ins(layers_);
  net_ = vision::load_onnx_network(model_path_, "ppocr detector");
  // One pass on a blank input: a file converted for another size fails here, not per image.
  const int shape[] = {1, 3, input_size_.height, input_size_.width};
  if (probability_map(cv::Mat(4, shape, CV_32F, cv::Scalar(0))).empty()) {
    net_ = cv::dnn::Net();
    throw StartupError("ppocr detector: '" + model_path_ + "' does not give a " +
                       std::to_string(input_size_.width) + "x" +
                       std::to_string(input_size_.height) + " probability map");
  }
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
  if (net_.empty()) build();
  const float scale = std::min(float(input_size_.width) / float(bgr.cols),
                               float(input_size_.height) / float(bgr.rows));
  const cv::Size fitted(std::clamp(cvRound(float(bgr.cols) * scale), 1, input_size_.width),
                        std::clamp(cvRound(float(bgr.rows) * scale), 1, input_size_.height));
  try {
    const cv::Mat* fitted_image = &bgr;
    if (fitted != bgr.size()) {
      cv::resize(bgr, resized_, fitted, 0, 0, cv::INTER_LINEAR);
      fitted_image = &resized_;
    }
    ppocr::fill_input_planes(*fitted_image, input_size_, input_);
    const cv::Mat prob = probability_map(input_);
    if (prob.empty()) return {};
    return vision::db_postprocess(prob, fitted, scale, bgr.size(), params_);
  } catch (const cv::Exception&) {
    return {};
  }
}

}  // namespace keyfleet::station
