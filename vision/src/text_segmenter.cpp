#include "keyfleet/vision/text_segmenter.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/json_integer.hpp"
#include "keyfleet/vision/model_files.hpp"

namespace keyfleet::vision {
namespace {

// The "db" object of a text_probability description; DB's defaults where a field is absent.
DbParams read_db_params(const nlohmann::json& db) {
  DbParams params;
  params.binary_threshold = db.value("binary_threshold", params.binary_threshold);
  params.box_threshold = db.value("box_threshold", params.box_threshold);
  params.unclip_ratio = db.value("unclip_ratio", params.unclip_ratio);
  params.min_size = db.value("min_size", params.min_size);
  for (const float v : {params.binary_threshold, params.box_threshold})
    if (!(v >= 0 && v <= 1)) throw std::runtime_error("db thresholds must lie in [0, 1]");
  if (!(params.unclip_ratio >= 0) || !std::isfinite(params.unclip_ratio) ||
      !(params.min_size >= 0) || !std::isfinite(params.min_size))
    throw std::runtime_error("db unclip_ratio and min_size must be finite and >= 0");
  return params;
}

}  // namespace

SegmenterInfo read_segmenter_info(const std::string& model_path) {
  const std::string path = std::filesystem::path(model_path).replace_extension(".json").string();
  std::ifstream in(path);
  if (!in)
    throw StartupError("segmenter: missing model description " + path + " (beside " + model_path +
                       ")");
  try {
    const auto j = nlohmann::json::parse(in);
    if (j.at("format") != "keyfleet-segmenter")
      throw std::runtime_error("not a keyfleet segmenter");
    SegmenterInfo info;
    info.input_size = {json_integer<int>(j.at("input_width")),
                       json_integer<int>(j.at("input_height"))};
    info.size_multiple = json_integer_or(j, "size_multiple", 1);
    info.max_batch = json_integer_or(j, "max_batch", 0);
    if (info.max_batch < 0) throw std::runtime_error("max_batch must be >= 0");
    info.scale = j.at("scale");
    const auto& mean = j.at("mean_bgr");
    info.mean_bgr = cv::Scalar(mean.at(0), mean.at(1), mean.at(2));
    if (j.contains("std_bgr")) {
      const auto& std_bgr = j.at("std_bgr");
      info.std_bgr = cv::Scalar(std_bgr.at(0), std_bgr.at(1), std_bgr.at(2));
      for (int c = 0; c < 3; ++c)
        if (!(info.std_bgr[c] > 0) || !std::isfinite(info.std_bgr[c]))
          throw std::runtime_error("std_bgr must be positive and finite");
    }
    const std::string output = j.value("output", "class_logits");
    if (output == "text_probability") {
      info.output = SegmenterInfo::Output::kTextProbability;
      info.boxes = read_db_params(j.value("db", nlohmann::json::object()));
    } else if (output != "class_logits") {
      throw std::runtime_error("output '" + output +
                               "' is neither class_logits nor text_probability");
    }
    info.classes = j.at("classes").get<std::vector<std::string>>();
    info.description = j.value("description", "");
    info.gflops_512x256 = j.value("gflops_512x256", 0.0);
    for (const auto& name : j.at("target_classes")) {
      const auto it = std::find(info.classes.begin(), info.classes.end(), name.get<std::string>());
      if (it == info.classes.end())
        throw std::runtime_error("target class '" + name.get<std::string>() + "' is not a class");
      info.target_classes.push_back(int(it - info.classes.begin()));
    }
    if (info.input_size.width <= 0 || info.input_size.height <= 0 || info.size_multiple <= 0 ||
        info.input_size.width % info.size_multiple || info.input_size.height % info.size_multiple)
      throw std::runtime_error("input size must be positive multiples of size_multiple");
    if (info.target_classes.empty()) throw std::runtime_error("no target classes");
    if (info.output == SegmenterInfo::Output::kTextProbability && info.classes.size() != 1)
      throw std::runtime_error("a text_probability output has one class");
    return info;
  } catch (const std::exception& e) {
    throw StartupError("segmenter: " + path + ": " + e.what());
  }
}

DnnTextSegmenter::DnnTextSegmenter(const std::string& model_path, int threads,
                                   std::optional<cv::Size> input_size, DnnLayers layers)
    : info_(read_segmenter_info(model_path)) {
  if (input_size) info_.input_size = *input_size;
  // OpenCV creates the layers while importing and on the first forward pass (the probe below).
  std::optional<DnnLayersScope> stand_ins;
  if (layers.any()) stand_ins.emplace(layers);
  net_ = load_onnx_network(model_path, "segmenter");
  if (threads > 0) cv::setNumThreads(threads);
  std::vector<cv::Mat> probe;
  try {
    probe = segment({cv::Mat(info_.input_size, CV_8UC3, cv::Scalar::all(128))});
  } catch (const cv::Exception& e) {
    throw StartupError("segmenter: " + model_path + " does not run on " +
                       std::to_string(info_.input_size.width) + "x" +
                       std::to_string(info_.input_size.height) + " BGR input: " + e.what());
  } catch (const std::runtime_error& e) {
    throw StartupError("segmenter: " + model_path + ": " + e.what());
  }
}

std::vector<DnnTextSegmenter::LayerTime> DnnTextSegmenter::last_forward_layers() const {
  cv::dnn::Net net = net_;  // a handle: getPerfProfile is not const
  std::vector<double> ticks;
  net.getPerfProfile(ticks);
  const std::vector<cv::String> names = net.getLayerNames();
  std::vector<LayerTime> layers;
  for (std::size_t i = 0; i < names.size() && i < ticks.size(); ++i)
    layers.push_back(
        {names[i], net.getLayer(names[i])->type, ticks[i] * 1000.0 / cv::getTickFrequency()});
  return layers;
}

std::map<std::string, double> DnnTextSegmenter::last_forward_ms_by_type() const {
  std::map<std::string, double> ms;
  for (const auto& layer : last_forward_layers()) ms[layer.type] += layer.ms;
  return ms;
}

std::vector<cv::Mat> DnnTextSegmenter::segment(const std::vector<cv::Mat>& frames) {
  if (frames.empty()) return {};
  if (info_.max_batch > 0 && int(frames.size()) > info_.max_batch) {
    std::vector<cv::Mat> masks;
    for (std::size_t first = 0; first < frames.size(); first += std::size_t(info_.max_batch)) {
      const auto end = frames.begin() + std::ptrdiff_t(std::min(
                                            frames.size(), first + std::size_t(info_.max_batch)));
      for (auto& mask : segment(std::vector<cv::Mat>(frames.begin() + std::ptrdiff_t(first), end)))
        masks.push_back(std::move(mask));
    }
    return masks;
  }
  cv::Mat blob = cv::dnn::blobFromImages(frames, info_.scale, info_.input_size, info_.mean_bgr,
                                         false, false, CV_32F);
  if (info_.std_bgr != cv::Scalar(1, 1, 1))
    for (int i = 0; i < blob.size[0]; ++i)
      for (int c = 0; c < 3; ++c) {
        cv::Mat plane(info_.input_size, CV_32F, blob.ptr<float>(i, c));
        plane *= 1.0 / info_.std_bgr[c];
      }
  net_.setInput(blob);
  const cv::Mat out = net_.forward();
  const int n = int(frames.size()), classes = int(info_.classes.size());
  if (out.dims != 4 || out.size[0] != n || out.size[1] != classes ||
      out.size[2] != info_.input_size.height || out.size[3] != info_.input_size.width)
    throw std::runtime_error("network output is not N x " + std::to_string(classes) + " x " +
                             std::to_string(info_.input_size.height) + " x " +
                             std::to_string(info_.input_size.width));
  const int h = out.size[2], w = out.size[3];
  std::vector<cv::Mat> masks;
  if (info_.output == SegmenterInfo::Output::kTextProbability) {
    for (int i = 0; i < n; ++i) {
      const cv::Mat prob(h, w, CV_32F, const_cast<float*>(out.ptr<float>(i, 0)));
      const cv::Size size(w, h);
      masks.push_back(fill_boxes(db_postprocess(prob, size, 1.f, size, info_.boxes), size));
    }
    return masks;
  }
  for (int i = 0; i < n; ++i) {
    // A pixel is text where a target class has the largest logit.
    cv::Mat best(h, w, CV_32F, cv::Scalar(-1e30f)), is_target = cv::Mat::zeros(h, w, CV_8U);
    for (int c = 0; c < classes; ++c) {
      const cv::Mat logits(h, w, CV_32F, const_cast<float*>(out.ptr<float>(i, c)));
      const cv::Mat higher = logits > best;
      logits.copyTo(best, higher);
      const bool target = std::find(info_.target_classes.begin(), info_.target_classes.end(), c) !=
                          info_.target_classes.end();
      is_target.setTo(target ? 255 : 0, higher);
    }
    masks.push_back(is_target);
  }
  return masks;
}

DnnLayers semantic_layers(const SemanticConfig& config) {
  DnnLayers layers;
  layers.bfloat16_products = config.bfloat16;
  layers.int8_pointwise = config.int8;
  return layers;
}

std::unique_ptr<DnnTextSegmenter> make_text_segmenter(const SemanticConfig& config) {
  return std::make_unique<DnnTextSegmenter>(locate_model(config.model, "segmenter model"),
                                            config.threads, std::nullopt, semantic_layers(config));
}

}  // namespace keyfleet::vision
