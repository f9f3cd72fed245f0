#include "keyfleet/vision/place_describer.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/json_integer.hpp"
#include "keyfleet/vision/model_files.hpp"

namespace keyfleet::vision {

PlaceDescriberInfo read_place_describer_info(const std::string& model_path) {
  const std::string path = std::filesystem::path(model_path).replace_extension(".json").string();
  std::ifstream in(path);
  if (!in)
    throw StartupError("place descriptor: missing model description " + path + " (beside " +
                       model_path + ")");
  try {
    const auto j = nlohmann::json::parse(in);
    if (j.at("format") != "keyfleet-place-descriptor")
      throw std::runtime_error("not a keyfleet place descriptor");
    PlaceDescriberInfo info;
    info.input_size = {json_integer<int>(j.at("input_width")),
                       json_integer<int>(j.at("input_height"))};
    info.scale = j.at("scale");
    const auto& mean = j.at("mean_bgr");
    info.mean_bgr = cv::Scalar(mean.at(0), mean.at(1), mean.at(2));
    info.dimensions = json_integer<int>(j.at("dimensions"));
    info.description = j.value("description", "");
    if (info.input_size.width <= 0 || info.input_size.height <= 0)
      throw std::runtime_error("input size must be positive");
    if (info.dimensions <= 0 || info.dimensions > 65536)
      throw std::runtime_error("dimensions must be in [1, 65536]");
    if (!std::isfinite(info.scale) || info.scale <= 0)
      throw std::runtime_error("scale must be a positive number");
    return info;
  } catch (const std::exception& e) {
    throw StartupError("place descriptor: " + path + ": " + e.what());
  }
}

void l2_normalise(std::vector<float>& v) {
  double sum = 0;
  for (float x : v) sum += double(x) * x;
  if (sum <= 0) return;
  const auto inverse = static_cast<float>(1.0 / std::sqrt(sum));
  for (float& x : v) x *= inverse;
}

DnnPlaceDescriber::DnnPlaceDescriber(const std::string& model_path, DnnLayers layers)
    : info_(read_place_describer_info(model_path)) {
  // OpenCV creates the layers while importing and on the first forward pass (the probe below).
  std::optional<DnnLayersScope> stand_ins;
  if (layers.any()) stand_ins.emplace(layers);
  net_ = load_onnx_network(model_path, "place descriptor");
  try {
    describe(cv::Mat(info_.input_size, CV_8UC3, cv::Scalar::all(128)));
  } catch (const cv::Exception& e) {
    throw StartupError("place descriptor: " + model_path + " does not run on " +
                       std::to_string(info_.input_size.width) + "x" +
                       std::to_string(info_.input_size.height) + " BGR input: " + e.what());
  } catch (const std::runtime_error& e) {
    throw StartupError("place descriptor: " + model_path + ": " + e.what());
  }
}

std::vector<float> DnnPlaceDescriber::describe(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3)
    throw std::invalid_argument("place descriptor: expects a non-empty 8-bit BGR image");
  const cv::Mat* view = &bgr;
  if (bgr.size() != info_.input_size) {
    cv::resize(bgr, resized_, info_.input_size, 0, 0, cv::INTER_AREA);
    view = &resized_;
  }
  net_.setInput(cv::dnn::blobFromImage(*view, info_.scale, {}, info_.mean_bgr));
  const cv::Mat out = net_.forward();
  if (out.total() != static_cast<std::size_t>(info_.dimensions) || out.depth() != CV_32F)
    throw std::runtime_error("the network gives " + std::to_string(out.total()) +
                             " values, the description says " + std::to_string(info_.dimensions));
  std::vector<float> descriptor(out.ptr<float>(), out.ptr<float>() + info_.dimensions);
  l2_normalise(descriptor);
  return descriptor;
}

}  // namespace keyfleet::vision
