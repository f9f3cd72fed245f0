#pragma once
// The holistic place descriptor's seam: one vector per view, L2-normalised, so that the cosine
// similarity of two views is their dot product. The real implementation runs an ONNX model
// (models/placenet) through OpenCV DNN, described by a JSON file beside it.
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include <string>
#include <vector>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {

struct PlaceDescriberInfo {
  cv::Size input_size;         // views are resized to this (area interpolation)
  double scale = 1.0 / 127.5;  // blob = (pixel - mean) * scale, BGR order
  cv::Scalar mean_bgr{127.5, 127.5, 127.5};
  int dimensions = 0;
  std::string description;
};

class PlaceDescriber {
 public:
  virtual ~PlaceDescriber() = default;
  // An L2-normalised descriptor of a BGR view of any size.
  virtual std::vector<float> describe(const cv::Mat& bgr) = 0;
  virtual const PlaceDescriberInfo& info() const = 0;
};

// Reads the JSON description beside `model_path` (same name, .json). Throws StartupError.
PlaceDescriberInfo read_place_describer_info(const std::string& model_path);

// Scales `v` to unit length in place; a zero vector stays zero.
void l2_normalise(std::vector<float>& v);

// Not thread-safe (one OpenCV network): one per thread that describes.
class DnnPlaceDescriber final : public PlaceDescriber {
 public:
  // Loads the model and runs it once at its input size: a missing or corrupt file, or a
  // network whose output is not `dimensions` long, is a StartupError naming the file. `layers`:
  // keyfleet's stand-ins for its layers (dnn_layers.hpp; in float, the same descriptor to float
  // rounding: PlaceNet at 160x120 about 0.85 ms a view on one AVX2 thread against 1.3 with
  // OpenCV's own); DnnLayers::opencv() keeps OpenCV's.
  explicit DnnPlaceDescriber(const std::string& model_path,
                             DnnLayers layers = DnnLayers::in_float());
  std::vector<float> describe(const cv::Mat& bgr) override;
  const PlaceDescriberInfo& info() const override { return info_; }

 private:
  PlaceDescriberInfo info_;
  cv::dnn::Net net_;
  cv::Mat resized_;
};

}  // namespace keyfleet::vision
