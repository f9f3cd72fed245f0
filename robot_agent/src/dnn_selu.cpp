#include "keyfleet/agent/dnn_selu.hpp"

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/dnn/layer.hpp>

#include <algorithm>
#include <mutex>

namespace keyfleet::agent {

void selu_vectorised(const float* src, float* dst, int n, float alpha, float gamma) {
  // Branch-free (signs are random: branches mispredict): e = exp(min(x, 0)) a chunk at a time.
  constexpr int kChunk = 512;
  float e[kChunk];
  const cv::v_float32 zero = cv::vx_setzero_f32(), one = cv::vx_setall_f32(1.f),
                      a = cv::vx_setall_f32(alpha), g = cv::vx_setall_f32(gamma);
  constexpr int kLanes = cv::v_float32::nlanes;
  for (int start = 0; start < n; start += kChunk) {
    const int m = std::min(kChunk, n - start);
    const float* s = src + start;
    float* d = dst + start;
    int i = 0;
    for (; i + kLanes <= m; i += kLanes) cv::v_store(e + i, cv::v_min(cv::vx_load(s + i), zero));
    for (; i < m; ++i) e[i] = std::min(s[i], 0.f);
    cv::hal::exp32f(e, e, m);
    i = 0;
    for (; i + kLanes <= m; i += kLanes) {
      const cv::v_float32 neg = a * (cv::vx_load(e + i) - one);
      cv::v_store(d + i, g * (cv::v_max(cv::vx_load(s + i), zero) + neg));
    }
    for (; i < m; ++i) d[i] = gamma * (std::max(s[i], 0.f) + alpha * (e[i] - 1.f));
  }
}

namespace {

class VectorisedSeluLayer final : public cv::dnn::ActivationLayer {
 public:
  explicit VectorisedSeluLayer(const cv::dnn::LayerParams& params)
      // ONNX's defaults (those of the SELU paper), as OpenCV's importer passes them through.
      : alpha_(params.get<float>("alpha", 1.67326319217681884765625f)),
        gamma_(params.get<float>("gamma", 1.05070102214813232421875f)) {
    setParamsFrom(params);
  }

  static cv::Ptr<cv::dnn::Layer> create(cv::dnn::LayerParams& params) {
    return cv::makePtr<VectorisedSeluLayer>(params);
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int required_outputs,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>& internals) const override {
    cv::dnn::Layer::getMemoryShapes(inputs, required_outputs, outputs, internals);
    return true;  // may run in place
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      CV_Assert(inputs[i].type() == CV_32F && inputs[i].isContinuous() &&
                outputs[i].isContinuous() && inputs[i].total() == outputs[i].total());
      selu_vectorised(inputs[i].ptr<float>(), outputs[i].ptr<float>(), int(inputs[i].total()),
                      alpha_, gamma_);
    }
  }

  // What a convolution or sum calls after computing output channels [cn0, cn1) of a slice.
  void forwardSlice(const float* src, float* dst, int len, size_t plane_size, int cn0,
                    int cn1) const override {
    for (int c = cn0; c < cn1; ++c, src += plane_size, dst += plane_size)
      selu_vectorised(src, dst, len, alpha_, gamma_);
  }

 private:
  float alpha_, gamma_;
};

// One scope at a time: OpenCV refuses a second registration of the same constructor.
std::mutex& scope_mutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

VectorisedSeluScope::VectorisedSeluScope() {
  scope_mutex().lock();
  cv::dnn::LayerFactory::registerLayer("Selu", VectorisedSeluLayer::create);
}

VectorisedSeluScope::~VectorisedSeluScope() {
  cv::dnn::LayerFactory::unregisterLayer("Selu");
  scope_mutex().unlock();
}

}  // namespace keyfleet::agent
