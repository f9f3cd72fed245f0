#pragma once
// A stand-in layer that holds the OpenCV layer it stands in for: that layer gives the output
// shapes and finalises, and the stand-in hands it what it does not take. Internal to
// keyfleet_vision (elementwise_sum.cpp, nearest_upsampling.cpp).
#include <opencv2/dnn.hpp>

#include <string>
#include <utility>
#include <vector>

namespace keyfleet::vision {

template <class OpenCvLayer>
class OpenCvBackedLayer : public cv::dnn::Layer {
 public:
  OpenCvBackedLayer(const cv::dnn::LayerParams& params, cv::Ptr<OpenCvLayer> opencv,
                    const char* layer_type)
      : opencv_(std::move(opencv)) {
    setParamsFrom(params);
    type = layer_type;
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int required,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>& internals) const override {
    return opencv_->getMemoryShapes(inputs, required, outputs, internals);
  }

  void finalize(cv::InputArrayOfArrays inputs, cv::OutputArrayOfArrays outputs) override {
    opencv_->finalize(inputs, outputs);
  }

 protected:
  cv::Ptr<OpenCvLayer> opencv_;
};

}  // namespace keyfleet::vision
