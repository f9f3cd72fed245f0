// The element-wise sum stand-in (dense_layers.hpp): the FPN's additions in PP-OCR's detector.
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <algorithm>
#include <cctype>
#include <string>
#include <utility>
#include <vector>

#include "dense_layers.hpp"
#include "opencv_backed_layer.hpp"

namespace keyfleet::vision {
namespace {

// dst = a + b, n floats (dst may be a or b).
void add(const float* a, const float* b, float* dst, int n) {
  int i = 0;
#if CV_SIMD
  constexpr int kLanes = cv::v_float32::nlanes;
  for (; i + 2 * kLanes <= n; i += 2 * kLanes) {
    const cv::v_float32 x0 = cv::vx_load(a + i) + cv::vx_load(b + i);
    const cv::v_float32 x1 = cv::vx_load(a + i + kLanes) + cv::vx_load(b + i + kLanes);
    cv::v_store(dst + i, x0);
    cv::v_store(dst + i + kLanes, x1);
  }
#endif
  for (; i < n; ++i) dst[i] = a[i] + b[i];
}

// Whether m is a 4-D float blob whose planes are each contiguous (its images may lie apart: an
// output may be a slice of a concatenation's channels).
bool planes_contiguous(const cv::Mat& m) {
  return m.dims == 4 && m.type() == CV_32F && m.step[3] == sizeof(float) &&
         m.step[2] == m.step[3] * std::size_t(m.size[3]) &&
         m.step[1] == m.step[2] * std::size_t(m.size[2]);
}

// ONNX Add (and Sum) of inputs of one shape: OpenCV 4.6's Eltwise layer adds them in blocks of
// 4,096 values that visit every channel's plane in turn, one element at a time (PP-OCR's detector
// at 640x480 adds two 96 x 120 x 160 maps in its FPN; what that cost and what this saves:
// docs/results/2026-11-28-sums-and-depthwise.md). This one adds whole planes in SIMD, in
// OpenCV's order ((x0 + x1) + x2 ...: the same floats), then applies a fused activation to the
// plane. Anything else (products, maxima, coefficients other than 1, inputs of other shapes or
// channel counts) runs the OpenCV layer this one holds, which also gives the shapes.
class ElementwiseSumLayer final : public OpenCvBackedLayer<cv::dnn::EltwiseLayer> {
 public:
  ElementwiseSumLayer(const cv::dnn::LayerParams& params, cv::Ptr<cv::dnn::EltwiseLayer> opencv)
      : OpenCvBackedLayer(params, std::move(opencv), "KeyfleetSum") {}

  static bool handles(const cv::dnn::LayerParams& params) {
    if (params.has("operation")) {
      std::string operation = params.get<cv::String>("operation");
      std::transform(operation.begin(), operation.end(), operation.begin(),
                     [](unsigned char c) { return char(std::tolower(c)); });
      if (operation != "sum") return false;
    }
    if (params.has("output_channels_mode") &&
        params.get<cv::String>("output_channels_mode") != "same")
      return false;
    if (params.has("coeff")) {
      const cv::dnn::DictValue& coeff = params.get("coeff");
      for (int i = 0; i < coeff.size(); ++i)
        if (coeff.get<float>(i) != 1.f) return false;
    }
    return true;
  }

  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    if (!opencv_->setActivation(layer)) return false;
    activation_ = layer;
    return !activation_.empty();
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    if (outputs.size() != 1 || !takes(inputs, outputs[0])) {
      opencv_->forward(inputs_arr, outputs_arr, internals_arr);
      return;
    }
    cv::Mat& out = outputs[0];
    const int channels = out.size[1], plane = out.size[2] * out.size[3];
    const cv::dnn::ActivationLayer* activation = activation_.get();
    cv::parallel_for_(cv::Range(0, out.size[0] * channels), [&](const cv::Range& range) {
      for (int p = range.start; p < range.end; ++p) {
        // Images apart: the output may be a slice of a concatenation's channels.
        const int image = p / channels, channel = p % channels;
        const std::size_t offset = std::size_t(channel) * plane;
        float* dst = out.ptr<float>(image) + offset;
        add(inputs[0].ptr<float>(image) + offset, inputs[1].ptr<float>(image) + offset, dst, plane);
        for (std::size_t k = 2; k < inputs.size(); ++k)
          add(dst, inputs[k].ptr<float>(image) + offset, dst, plane);
        if (activation) activation->forwardSlice(dst, dst, plane, plane, channel, channel + 1);
      }
    });
  }

 private:
  static bool takes(const std::vector<cv::Mat>& inputs, const cv::Mat& out) {
    if (inputs.size() < 2 || !planes_contiguous(out)) return false;
    for (const cv::Mat& in : inputs)
      if (!planes_contiguous(in) || in.size != out.size) return false;
    return true;
  }

  cv::Ptr<cv::dnn::ActivationLayer> activation_;
};

}  // namespace

cv::Ptr<cv::dnn::Layer> create_eltwise(cv::dnn::LayerParams& params) {
  cv::Ptr<cv::dnn::EltwiseLayer> opencv = cv::dnn::EltwiseLayer::create(params);
  if (!ElementwiseSumLayer::handles(params)) return opencv;
  return cv::makePtr<ElementwiseSumLayer>(params, opencv);
}

}  // namespace keyfleet::vision
