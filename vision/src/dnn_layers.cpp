#include "keyfleet/vision/dnn_layers.hpp"

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/dnn/layer.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>

#include "activation_chain.hpp"
#include "avx2_product.hpp"
#include "bf16_product.hpp"
#include "convolution_layers.hpp"
#include "dense_layers.hpp"
#include "selu_avx2.hpp"

namespace keyfleet::vision {

DnnLayers& scope_layers() {
  static DnnLayers layers;  // one scope at a time
  return layers;
}

void selu_vectorised(const float* src, float* dst, int n, float alpha, float gamma) {
  const int done = selu_avx2(src, dst, n, alpha, gamma);
  src += done;
  dst += done;
  n -= done;
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

void hard_swish_vectorised(const float* src, float* dst, int n) {
  hard_swish_scale_shift_vectorised(src, dst, n, 1.f, 0.f);
}

namespace {

// An element-wise activation computed by apply(src, dst, n) over whole planes; OpenCV fuses it
// into the convolution or sum before it where that layer takes an activation. Base: the OpenCV
// class it stands in for (what OpenCV's fusions look for).
template <class Base = cv::dnn::ActivationLayer>
class PlaneActivationLayer : public Base {
 public:
  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int required_outputs,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>& internals) const override {
    this->cv::dnn::Layer::getMemoryShapes(inputs, required_outputs, outputs, internals);
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
      apply(inputs[i].ptr<float>(), outputs[i].ptr<float>(), int(inputs[i].total()));
    }
  }

  // What a convolution or sum calls after computing output channels [cn0, cn1) of a slice.
  void forwardSlice(const float* src, float* dst, int len, size_t plane_size, int cn0,
                    int cn1) const override {
    for (int c = cn0; c < cn1; ++c, src += plane_size, dst += plane_size) apply(src, dst, len);
  }

 protected:
  virtual void apply(const float* src, float* dst, int n) const = 0;
};

class HardSwishLayer final : public PlaneActivationLayer<> {
 public:
  explicit HardSwishLayer(const cv::dnn::LayerParams& params) { setParamsFrom(params); }
  static cv::Ptr<cv::dnn::Layer> create(cv::dnn::LayerParams& params) {
    return cv::makePtr<HardSwishLayer>(params);
  }

 private:
  void apply(const float* src, float* dst, int n) const override {
    hard_swish_vectorised(src, dst, n);
  }
};

// The logistic function 1 / (1 + exp(-x)) with OpenCV's vectorised exp, a chunk at a time (PP-OCR's
// detector ends in it: 82,000 values at 320x256), where OpenCV 4.6 takes one element at a time.
class SigmoidLayer final : public PlaneActivationLayer<> {
 public:
  explicit SigmoidLayer(const cv::dnn::LayerParams& params) { setParamsFrom(params); }
  static cv::Ptr<cv::dnn::Layer> create(cv::dnn::LayerParams& params) {
    return cv::makePtr<SigmoidLayer>(params);
  }

 private:
  void apply(const float* src, float* dst, int n) const override {
    constexpr int kChunk = 512;
    float e[kChunk];
    const cv::v_float32 one = cv::vx_setall_f32(1.f);
    constexpr int kLanes = cv::v_float32::nlanes;
    for (int start = 0; start < n; start += kChunk) {
      const int m = std::min(kChunk, n - start);
      for (int i = 0; i < m; ++i) e[i] = -src[start + i];
      cv::hal::exp32f(e, e, m);
      int i = 0;
      for (; i + kLanes <= m; i += kLanes)
        cv::v_store(dst + start + i, one / (one + cv::vx_load(e + i)));
      for (; i < m; ++i) dst[start + i] = 1.f / (1.f + e[i]);
    }
  }
};

class VectorisedSeluLayer final : public PlaneActivationLayer<> {
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

 private:
  void apply(const float* src, float* dst, int n) const override {
    selu_vectorised(src, dst, n, alpha_, gamma_);
  }
  float alpha_, gamma_;
};

// OpenCV's Power layer, (shift + scale x)^power, which its ONNX importer makes of a multiplication
// or addition by a constant: OpenCV 4.6 computes it one element at a time; this one in SIMD where
// power is 1 (PP-OCR's learnable affine blocks), else with std::pow. A PowerLayer still, so
// OpenCV's own convolutions fold it into their weights as they do the original.
class VectorisedPowerLayer final : public PlaneActivationLayer<cv::dnn::PowerLayer> {
 public:
  explicit VectorisedPowerLayer(const cv::dnn::LayerParams& params) {
    setParamsFrom(params);
    power = params.get<float>("power", 1.f);
    scale = params.get<float>("scale", 1.f);
    shift = params.get<float>("shift", 0.f);
  }
  static cv::Ptr<cv::dnn::Layer> create(cv::dnn::LayerParams& params) {
    return cv::makePtr<VectorisedPowerLayer>(params);
  }

 private:
  void apply(const float* src, float* dst, int n) const override {
    if (power != 1.f) {
      for (int i = 0; i < n; ++i) dst[i] = std::pow(shift + scale * src[i], power);
      return;
    }
    scale_shift_vectorised(src, dst, n, scale, shift);
  }
};

}  // namespace

bool is_hard_swish_stand_in(const cv::dnn::Layer* layer) {
  return dynamic_cast<const HardSwishLayer*>(layer) != nullptr;
}

bool matrix_product_layers_supported() { return product_supported(); }

bool bfloat16_products_supported() { return product_supported() && bf16_product_supported(); }

namespace {
thread_local DnnLayersScope* current_scope = nullptr;
}  // namespace

DnnLayersScope* DnnLayersScope::current() { return current_scope; }

void DnnLayersScope::watch(const cv::dnn::Net& net) { watched_.push_back(net); }

bool DnnLayersScope::readers(const cv::dnn::Layer& layer,
                             std::vector<cv::Ptr<cv::dnn::Layer>>& found) {
  readers_.resize(watched_.size());
  for (std::size_t i = 0; i < watched_.size(); ++i) {
    cv::dnn::Net& net = watched_[i];
    const int id = net.getLayerId(layer.name);
    if (id < 0 || net.getLayer(id).get() != &layer) continue;
    auto& index = readers_[i];
    if (index.empty())
      for (const cv::String& name : net.getLayerNames()) {
        const int other = net.getLayerId(name);
        for (const cv::Ptr<cv::dnn::Layer>& input : net.getLayerInputs(other))
          index[input.get()].push_back(net.getLayer(other));
      }
    const auto it = index.find(&layer);
    found = it == index.end() ? std::vector<cv::Ptr<cv::dnn::Layer>>() : it->second;
    return true;
  }
  return false;
}

std::mutex& DnnLayersScope::scope_mutex() {
  static std::mutex mutex;
  return mutex;
}

DnnLayersScope::DnnLayersScope(DnnLayers layers) : lock_(scope_mutex()) {
  scope_layers() = layers;
  current_scope = this;
  const std::pair<bool, std::pair<const char*, cv::dnn::LayerFactory::Constructor>> chosen[] = {
      {layers.vectorised_selu, {"Selu", VectorisedSeluLayer::create}},
      {layers.vectorised_hard_swish, {"HardSwish", HardSwishLayer::create}},
      {layers.vectorised_sigmoid, {"Sigmoid", SigmoidLayer::create}},
      {layers.vectorised_power, {"Power", VectorisedPowerLayer::create}},
      {layers.depthwise || layers.pointwise || layers.dense_3x3,
       {"Convolution", create_convolution}},
      {layers.subpixel_deconvolution, {"Deconvolution", create_deconvolution}},
      {layers.inner_product, {"InnerProduct", create_inner_product}},
      {layers.vectorised_softmax, {"Softmax", create_softmax}},
      {layers.global_average_pool, {"Pooling", create_pooling}},
      {layers.nearest_upsampling, {"Resize", create_resize}},
      {layers.vectorised_sum, {"Eltwise", create_eltwise}},
      {layers.excited_sums && layers.pointwise, {"Scale", create_scale}}};
  try {
    for (const auto& [use, layer] : chosen)
      if (use) {
        cv::dnn::LayerFactory::registerLayer(layer.first, layer.second);
        registered_.push_back(layer.first);
      }
  } catch (...) {
    unregister();
    current_scope = nullptr;
    throw;
  }
}

DnnLayersScope::~DnnLayersScope() {
  unregister();
  current_scope = nullptr;
}

void DnnLayersScope::unregister() {
  for (const std::string& type : registered_) cv::dnn::LayerFactory::unregisterLayer(type);
  registered_.clear();
}

}  // namespace keyfleet::vision
