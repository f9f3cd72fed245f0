#include "convolution_layers.hpp"

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/dnn/layer.hpp>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "activation_chain.hpp"
#include "banded_depthwise.hpp"
#include "bf16_product.hpp"
#include "convolution_3x3.hpp"
#include "depthwise_avx2.hpp"
#include "fusion_order.hpp"
#include "layer_io.hpp"
#include "pointwise_convolution.hpp"
#include "pointwise_hand_over.hpp"
#include "pointwise_int8.hpp"
#include "strided_convolution.hpp"
#include "subpixel_deconvolution.hpp"
#include "upsampled_concatenation.hpp"
#include "upsampling_hand_over.hpp"

namespace keyfleet::vision {
namespace {

bool both_are(const std::vector<std::size_t>& values, std::size_t v) {
  return values.size() == 2 && values[0] == v && values[1] == v;
}

// Depthwise convolution, stride 1 along rows (2 with AVX2 and FMA for kernels other than 3x3:
// PP-OCR's detector halves its planes so with 5x5, 0.22 -> 0.07 ms at 320x256, while OpenCV's own
// 3x3 stride-2 kernel was faster than this one, 0.15 against 0.21) and any down columns (PP-OCR's
// recogniser halves its height so), any kernel, dilation and (zero) padding; NCHW float. With AVX2
// and FMA a row's taps are summed in registers (depthwise_avx2.hpp), else a pass per tap.
class DepthwiseLayer final : public cv::dnn::Layer {
 public:
  DepthwiseLayer(const cv::dnn::LayerParams& params, const cv::dnn::BaseConvolutionLayer& geometry)
      : kh_(int(geometry.kernel_size[0])),
        kw_(int(geometry.kernel_size[1])),
        dh_(int(geometry.dilations[0])),
        dw_(int(geometry.dilations[1])),
        pt_(int(geometry.pads_begin[0])),
        pl_(int(geometry.pads_begin[1])),
        pb_(int(geometry.pads_end[0])),
        pr_(int(geometry.pads_end[1])),
        sh_(int(geometry.strides[0])),
        sw_(int(geometry.strides[1])) {
    setParamsFrom(params);
    type = "KeyfleetDepthwise";  // not "Convolution": OpenCV's fusions expect its own class
    weights_ = blobs[0].reshape(1, blobs[0].size[0]);  // channels x (kh kw)
    if (blobs.size() > 1) bias_ = blobs[1].reshape(1, 1);
  }

  // A BandedDepthwise of this layer after a 1x1 layer of `channels` outputs, where it takes it.
  std::unique_ptr<BandedDepthwise> banded(int channels) const {
    if (sh_ != sw_ || kh_ != kw_ ||
        !BandedDepthwise::takes(blobs[0], bias_, channels, kh_, sh_, pt_, pl_, pb_, pr_, dh_, dw_))
      return nullptr;
    return std::make_unique<BandedDepthwise>(blobs[0], bias_, sh_);
  }

  // Convolutions the layer takes over; the others stay OpenCV's.
  static bool handles(const cv::dnn::LayerParams& params,
                      const cv::dnn::BaseConvolutionLayer& geometry) {
    if (params.blobs.empty() || params.blobs[0].dims != 4 || params.blobs[0].type() != CV_32F)
      return false;
    const cv::Mat& w = params.blobs[0];
    return geometry.kernel_size.size() == 2 && geometry.padMode.empty() && w.size[1] == 1 &&
           params.get<int>("group", 1) == w.size[0] && geometry.numOutput == w.size[0] &&
           geometry.strides.size() == 2 && geometry.strides[0] >= 1 &&
           (geometry.strides[1] == 1 || (geometry.strides[1] == 2 && depthwise_avx2_supported() &&
                                         !both_are(geometry.kernel_size, 3))) &&
           (params.blobs.size() < 2 || int(params.blobs[1].total()) == w.size[0]);
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    const cv::dnn::MatShape& in = inputs.at(0);
    CV_Assert(in.size() == 4 && in[1] == weights_.rows);
    // What the stride keeps of the padded height; none of none (OpenCV's importer asks about
    // empty planes, and a pooling branch beside this one answers 0).
    const int height = in[2] + pt_ + pb_ - dh_ * (kh_ - 1);
    const int width = in[3] + pl_ + pr_ - dw_ * (kw_ - 1);
    outputs = {{in[0], in[1], height <= 0 ? 0 : (height - 1) / sh_ + 1,
                width <= 0 ? 0 : (width - 1) / sw_ + 1}};
    return false;
  }

  // The activations after it, applied to each plane once computed.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    return activations_.add(layer);
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    LayerIo io = float_layer_io(inputs_arr, outputs_arr);
    const cv::Mat& in = io.in;
    cv::Mat& out = io.out;
    const int channels = in.size[1];
    const std::size_t out_plane = std::size_t(out.size[2]) * out.size[3];
    const cv::dnn::ActivationLayer* activation = activations_.get();
    cv::parallel_for_(cv::Range(0, in.size[0] * channels), [&](const cv::Range& planes) {
      for (int p = planes.start; p < planes.end; ++p) {
        float* dst = out.ptr<float>() + std::size_t(p) * out_plane;
        plane(in.ptr<float>() + std::size_t(p) * in.size[2] * in.size[3], in.size[2], in.size[3],
              p % channels, dst, out.size[2], out.size[3]);
        if (activation)
          activation->forwardSlice(dst, dst, int(out_plane), out_plane, p % channels,
                                   p % channels + 1);
      }
    });
  }

 private:
  void plane(const float* src, int h, int w, int channel, float* dst, int ho, int wo) const {
    if (depthwise_avx2_supported()) {
      depthwise_plane_avx2(src, h, w, weights_.ptr<float>(channel), kh_, kw_, dh_, dw_, pt_, pl_,
                           sh_, sw_, bias_.empty() ? 0.f : bias_.at<float>(channel), dst, ho, wo);
      return;
    }
    std::fill(dst, dst + std::size_t(ho) * wo, bias_.empty() ? 0.f : bias_.at<float>(channel));
    const float* kernel = weights_.ptr<float>(channel);
    constexpr int kLanes = cv::v_float32::nlanes;
    for (int ky = 0; ky < kh_; ++ky)
      for (int kx = 0; kx < kw_; ++kx) {
        const float weight = kernel[ky * kw_ + kx];
        if (weight == 0.f) continue;  // e.g. the added rows of export.py's squared kernels
        // Output (y, x) reads input (y sh - pt + ky dh, x - pl + kx dw): the rows and columns
        // where that lies inside the input (outside is zero padding, which adds nothing).
        const int dy = ky * dh_ - pt_, dx = kx * dw_ - pl_;
        const int y0 = dy >= 0 ? 0 : (-dy + sh_ - 1) / sh_;
        const int y1 = h - 1 - dy < 0 ? 0 : std::min(ho, (h - 1 - dy) / sh_ + 1);
        const int x0 = std::max(0, -dx), x1 = std::min(wo, w - dx);
        const cv::v_float32 vw = cv::vx_setall_f32(weight);
        for (int y = y0; y < y1; ++y) {
          const float* s = src + std::size_t(y * sh_ + dy) * w + dx;
          float* d = dst + std::size_t(y) * wo;
          int x = x0;
          for (; x + kLanes <= x1; x += kLanes)
            cv::v_store(d + x, cv::v_fma(vw, cv::vx_load(s + x), cv::vx_load(d + x)));
          for (; x < x1; ++x) d[x] += weight * s[x];
        }
      }
  }

  int kh_, kw_, dh_, dw_, pt_, pl_, pb_, pr_, sh_, sw_;
  cv::Mat weights_, bias_;
  ActivationChain activations_;
};

// A float layer run by a Kernel over each image of the batch, taking over the activation that
// follows it (OpenCV fuses it in; the kernel applies it while the output is in cache).
// Kernel: input_channels(), output_channels(), run(in, ..., out, activation).
template <class Kernel>
class ProductLayer : public cv::dnn::Layer {
 public:
  ProductLayer(const cv::dnn::LayerParams& params, const char* layer_type)
      : kernel_(params.blobs[0], params.blobs.size() > 1 ? params.blobs[1] : cv::Mat(),
                scope_layers().bfloat16_products) {
    setParamsFrom(params);
    type = std::string(layer_type) + (kernel_.bfloat16() ? "Bf16" : "");
  }

  // The activations after it (OpenCV offers each of a chain in turn), applied while the output is
  // in cache.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    return activations_.add(layer);
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    // The output may be a slice of a concatenation: images apart.
    LayerIo io = float_layer_io(inputs_arr, outputs_arr, false);
    const cv::Mat& in = io.in;
    cv::Mat& out = io.out;
    for (int n = 0; n < in.size[0]; ++n)
      run(in.ptr<float>(n), in.size[2], in.size[3], out.ptr<float>(n));
  }

 protected:
  virtual void run(const float* in, int height, int width, float* out) = 0;

  Kernel kernel_;
  ActivationChain activations_;
};

// A float convolution with one group, stride 1 and dilation 1 whose k x k kernel keeps the plane's
// size (padding k / 2 on every side): what the same-size product stand-ins take over.
bool same_size_convolution(const cv::dnn::LayerParams& params,
                           const cv::dnn::BaseConvolutionLayer& geometry, int k) {
  if (!product_supported() || params.blobs.empty() || params.blobs[0].dims != 4 ||
      params.blobs[0].type() != CV_32F)
    return false;
  const cv::Mat& w = params.blobs[0];
  return both_are(geometry.kernel_size, k) && both_are(geometry.strides, 1) &&
         both_are(geometry.dilations, 1) && both_are(geometry.pads_begin, k / 2) &&
         both_are(geometry.pads_end, k / 2) && geometry.padMode.empty() &&
         params.get<int>("group", 1) == 1 && geometry.numOutput == w.size[0] &&
         (params.blobs.size() < 2 || int(params.blobs[1].total()) == w.size[0]);
}

// A product stand-in whose output planes have the input's size.
template <class Kernel>
class SameSizeLayer : public ProductLayer<Kernel> {
 public:
  using ProductLayer<Kernel>::ProductLayer;

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    const cv::dnn::MatShape& in = inputs.at(0);
    CV_Assert(in.size() == 4 && in[1] == this->kernel_.input_channels());
    outputs = {{in[0], this->kernel_.output_channels(), in[2], in[3]}};
    return false;
  }
};

// OpenCV's own depthwise convolution `layer` as a BandedDepthwise after a 1x1 layer of
// `channels` outputs, where it is one that takes.
std::unique_ptr<BandedDepthwise> banded_opencv_depthwise(const cv::dnn::Layer& layer,
                                                         int channels) {
  const auto* conv = dynamic_cast<const cv::dnn::BaseConvolutionLayer*>(&layer);
  if (!conv || layer.type != "Convolution" || layer.blobs.empty() || !conv->padMode.empty() ||
      conv->numOutput != channels || conv->kernel_size.size() != 2 ||
      conv->kernel_size[0] != conv->kernel_size[1] || conv->strides.size() != 2 ||
      conv->strides[0] != conv->strides[1] || conv->pads_begin.size() != 2 ||
      conv->pads_end.size() != 2 || conv->dilations.size() != 2)
    return nullptr;
  const cv::Mat bias = layer.blobs.size() > 1 ? layer.blobs[1] : cv::Mat();
  const int k = int(conv->kernel_size[0]), stride = int(conv->strides[0]);
  if (!BandedDepthwise::takes(layer.blobs[0], bias, channels, k, stride, int(conv->pads_begin[0]),
                              int(conv->pads_begin[1]), int(conv->pads_end[0]),
                              int(conv->pads_end[1]), int(conv->dilations[0]),
                              int(conv->dilations[1])))
    return nullptr;
  return std::make_unique<BandedDepthwise>(layer.blobs[0], bias, stride);
}

// What a stand-in that may take over the depthwise convolution after it holds for that
// (banded_depthwise.hpp): whether the stand-ins allow it, the size of an image's output of the
// layer, the fused depthwise layer and the activations after it.
class DepthwiseFusion {
 public:
  explicit DepthwiseFusion(const cv::dnn::Layer& self)
      : self_(self), may_(scope_layers().banded_depthwise) {}

  // For OpenCV's tryFuse of `top` (not an activation) after a layer of `channels` outputs whose
  // kernel can write rows where asked (`can`), where `top` runs right after it (fusion_order.hpp).
  bool take(const cv::dnn::Layer& top, int channels, bool can) {
    if (banded_ || !may_ || !can || output_bytes_ < BandedDepthwise::kSmallestOutputBytes)
      return false;
    std::unique_ptr<BandedDepthwise> banded;
    if (const auto* depthwise = dynamic_cast<const DepthwiseLayer*>(&top))
      banded = depthwise->banded(channels);
    else
      banded = banded_opencv_depthwise(top, channels);
    if (!banded || !order_.runs_next(self_, top)) return false;
    banded_ = std::move(banded);
    order_.joined(top.name);
    return true;
  }

  // OpenCV's tryFuse of `top` on a layer whose own activations are `own`: an activation joins
  // that chain (or, once fused, the depthwise layer's); a depthwise layer that take() accepts is
  // fused, and the layer's `type` becomes `fused_type`.
  bool try_fuse(cv::Ptr<cv::dnn::Layer>& top, int channels, bool can, ActivationChain& own,
                std::string& type, const char* fused_type) {
    if (top.empty()) return false;
    if (const auto activation = top.dynamicCast<cv::dnn::ActivationLayer>())
      return add_activation(activation, own, type);
    if (!take(*top, channels, can)) return false;
    unfused_type_ = type;
    type = fused_type;
    return true;
  }

  // An activation for the layer's own chain or, once fused, the depthwise layer's (where it runs
  // right after the pair); an empty one (OpenCV's unsetAttached, before it fuses the network
  // again) undoes every fusion, the layer's `type` included.
  bool add_activation(const cv::Ptr<cv::dnn::ActivationLayer>& layer, ActivationChain& own,
                      std::string& type) {
    if (layer.empty()) {
      if (banded_) type = unfused_type_;
      banded_.reset();
      activations_.add(layer);
      order_.clear();
      return own.add(layer);
    }
    if (banded_ && !order_.runs_next(self_, *layer)) return false;
    if (!(banded_ ? activations_.add(layer) : own.add(layer))) return false;
    order_.joined(layer->name);
    return true;
  }

  // From finalize() (OpenCV finalizes every layer before it fuses any): the layer's output of
  // `channels` planes, each `side` of its input's height and width.
  template <class Side>
  void note_output(cv::InputArrayOfArrays inputs_arr, int channels, Side side) {
    std::vector<cv::Mat> inputs;
    inputs_arr.getMatVector(inputs);
    output_bytes_ = inputs.empty() || inputs[0].dims != 4
                        ? 0
                        : std::size_t(channels) * std::size_t(side(inputs[0].size[2])) *
                              std::size_t(side(inputs[0].size[3])) * sizeof(float);
  }

  bool fused() const { return bool(banded_); }

  // The fused pair on each image of `io`: the first layer's output is `channels` planes of h x w,
  // whose rows [first, last) produce(image's input, first, last, band, band_plane) writes.
  template <class Produce>
  void run(LayerIo& io, int channels, int h, int w, const Produce& produce) {
    // OpenCV hands the layer the depthwise layer's blobs.
    CV_Assert(io.out.dims == 4 && io.out.size[1] == channels &&
              io.out.size[2] == banded_->output_side(h) &&
              io.out.size[3] == banded_->output_side(w));
    const FusedOutput out(io.in, io.out, scratch_);
    for (int n = 0; n < io.in.size[0]; ++n) {
      const float* src = io.in.ptr<float>(n);
      banded_->run([&](int first, int last, float* band,
                       std::size_t band_plane) { produce(src, first, last, band, band_plane); },
                   h, w, out.image(n), activations_.get());
    }
    out.apply();
  }

 private:
  const cv::dnn::Layer& self_;
  bool may_;
  std::size_t output_bytes_ = 0;
  std::string unfused_type_;
  FusionOrder order_;
  std::unique_ptr<BandedDepthwise> banded_;
  ActivationChain activations_;
  std::vector<float> scratch_;
};

// 1x1 convolution, stride 1, no padding, one group, by avx2_product.hpp; an activation after it
// is applied as each stripe of columns is done. Where a depthwise convolution is the only reader
// of its (activated) output, it takes that one over too and runs both a band of rows at a time
// (banded_depthwise.hpp), with the activations after the depthwise one.
class PointwiseLayer final : public SameSizeLayer<PointwiseConvolution> {
 public:
  explicit PointwiseLayer(const cv::dnn::LayerParams& params)
      : SameSizeLayer(params, "KeyfleetPointwise"),
        may_hand_over_(scope_layers().excited_sums),
        unfused_type_(type) {}

  static bool handles(const cv::dnn::LayerParams& params,
                      const cv::dnn::BaseConvolutionLayer& geometry) {
    return same_size_convolution(params, geometry, 1);
  }

  // OpenCV's fusion offers the layers after this one in turn, each the only reader of the one
  // before, while this accepts: the activations (as setActivation would take them), then a
  // depthwise convolution, then the activations after that.
  bool tryFuse(cv::Ptr<cv::dnn::Layer>& top) override {
    return fusion_.try_fuse(top, kernel_.output_channels(), kernel_.runs_columns(), activations_,
                            type, "KeyfleetPointwiseDepthwise");
  }

  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    return fusion_.add_activation(layer, activations_, type);
  }

  // Where every reader of its output is a stand-in that takes it, one of them a channel scaling
  // (pointwise_hand_over.hpp), the output is left to them on each pass that allows it (one
  // image, nothing fused into this one).
  void finalize(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays) override {
    fusion_.note_output(inputs_arr, kernel_.output_channels(), [](int side) { return side; });
    const std::vector<cv::Ptr<cv::dnn::Layer>> readers =
        may_hand_over_ && kernel_.runs_columns() ? order_.readers(*this)
                                                 : std::vector<cv::Ptr<cv::dnn::Layer>>();
    handed_ = read_by_channel_scale(readers) && hand_over_to(readers, hand_over_);
    if (!handed_) withdraw_from(readers, hand_over_.get());
    if (!fusion_.fused()) type = handed_ ? unfused_type_ + "HandedOver" : unfused_type_;
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    if (handed_) {
      hand_over_->scales.clear();  // what the last pass left
      hand_over_->target = cv::Mat();
      LayerIo io = float_layer_io(inputs_arr, outputs_arr, false);
      if (io.in.size[0] == 1 && !activations_.get() && !fusion_.fused()) {
        io.in.copyTo(hand_over_->source);  // OpenCV may lay a later blob over the input
        hand_over_->target = io.out;
        return;
      }
    }
    if (!fusion_.fused()) {
      SameSizeLayer::forward(inputs_arr, outputs_arr, internals_arr);
      return;
    }
    LayerIo io = float_layer_io(inputs_arr, outputs_arr, false);
    const int h = io.in.size[2], w = io.in.size[3];
    fusion_.run(io, kernel_.output_channels(), h, w,
                [&](const float* src, int first, int last, float* band, std::size_t band_plane) {
                  kernel_.run_columns(src + std::size_t(first) * w, std::size_t(h) * w,
                                      (last - first) * w, band, band_plane, activations_.get());
                });
  }

  void run(const float* in, int height, int width, float* out) override {
    kernel_.run(in, height * width, out, activations_.get());
  }

 private:
  DepthwiseFusion fusion_{*this};
  bool may_hand_over_;
  std::string unfused_type_;
  FusionOrder order_;  // its readers, found in the watched network
  // Its own, the same at every set-up (the readers keep it while handed_).
  std::shared_ptr<PointwiseHandOver> hand_over_ =
      std::make_shared<PointwiseHandOver>(PointwiseHandOver{&kernel_, {}, {}, {}});
  bool handed_ = false;
};

// The same in 8-bit integers (pointwise_int8.hpp), where the scope asks for it.
class Int8PointwiseLayer final : public SameSizeLayer<Int8PointwiseConvolution> {
 public:
  explicit Int8PointwiseLayer(const cv::dnn::LayerParams& params)
      : SameSizeLayer(params, "KeyfleetPointwiseInt8") {}

  // Where the products outweigh quantizing the input: 64 or more input and output channels
  // (PP-OCR's detector: its 16 -> 32 layer at 240x320 took 3.1 ms in int8 against 2.6 in float,
  // 384 -> 384 at 30x40 0.7 against 1.15).
  static bool pays(const cv::dnn::LayerParams& params) {
    const cv::Mat& w = params.blobs[0];
    return std::min(w.size[0], w.size[1]) >= kInt8SmallestChannels;
  }
  static constexpr int kInt8SmallestChannels = 64;

  void run(const float* in, int height, int width, float* out) override {
    kernel_.run(in, height * width, out, activations_.get());
  }
};

// Dense 3x3 convolution, stride 1, padding 1, one group, by nine taps of the matrix product; an
// activation after it is applied as each plane is done. Where it alone reads a concatenation into
// which upsamplings by 4 or more hand their slices over unwritten (upsampling_hand_over.hpp), it
// computes their share at the small size (upsampled_concatenation.hpp) in float.
class Convolution3x3Layer final : public SameSizeLayer<Convolution3x3>, public SliceReader {
 public:
  explicit Convolution3x3Layer(const cv::dnn::LayerParams& params)
      : SameSizeLayer(params, "KeyfleetConvolution3x3") {
    if (scope_layers().upsampled_taps && !kernel_.bfloat16())
      concatenation_ = std::make_unique<UpsampledConcatenation>(
          params.blobs[0], params.blobs.size() > 1 ? params.blobs[1] : cv::Mat());
  }

  static bool handles(const cv::dnn::LayerParams& params,
                      const cv::dnn::BaseConvolutionLayer& geometry) {
    return same_size_convolution(params, geometry, 3);
  }

  bool read_upsampled_slice(std::shared_ptr<UpsamplingHandOver> hand_over) override {
    if (!concatenation_) return false;
    concatenation_->add(std::move(hand_over));
    return true;
  }

  // An empty layer: OpenCV undoes its fusions (before it fuses again), hand-overs included.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    if (layer.empty() && concatenation_) concatenation_->clear();
    return SameSizeLayer::setActivation(layer);
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    if (concatenation_ && concatenation_->waiting()) {
      LayerIo io = float_layer_io(inputs_arr, outputs_arr, false);
      if (io.out.size[0] == 1 &&
          concatenation_->run(io.in, io.out.ptr<float>(0), activations_.get()))
        return;
      concatenation_->write_waiting();
    }
    SameSizeLayer::forward(inputs_arr, outputs_arr, internals_arr);
  }

  void run(const float* in, int height, int width, float* out) override {
    kernel_.run(in, height, width, out, activations_.get());
  }

 private:
  std::unique_ptr<UpsampledConcatenation> concatenation_;  // float only
};

// Dense k x k convolution (k odd, padding k / 2 on every side), stride 2, one group, at most 4
// input channels: a network's first layer (strided_convolution.hpp); an activation after it is
// applied as each stripe of columns is done.
class StridedConvolutionLayer final : public cv::dnn::Layer {
 public:
  explicit StridedConvolutionLayer(const cv::dnn::LayerParams& params)
      : kernel_(params.blobs[0], params.blobs.size() > 1 ? params.blobs[1] : cv::Mat(),
                params.blobs[0].size[2] / 2) {
    setParamsFrom(params);
    type = "KeyfleetStridedConvolution";
  }

  static bool handles(const cv::dnn::LayerParams& params,
                      const cv::dnn::BaseConvolutionLayer& geometry) {
    if (!product_supported() || params.blobs.empty() || params.blobs[0].dims != 4 ||
        params.blobs[0].type() != CV_32F)
      return false;
    const cv::Mat& w = params.blobs[0];
    const int k = w.size[2];
    return k % 2 == 1 && w.size[3] == k && w.size[1] <= kMostInputs &&
           both_are(geometry.kernel_size, std::size_t(k)) && both_are(geometry.strides, 2) &&
           both_are(geometry.dilations, 1) && both_are(geometry.pads_begin, std::size_t(k / 2)) &&
           both_are(geometry.pads_end, std::size_t(k / 2)) && geometry.padMode.empty() &&
           params.get<int>("group", 1) == 1 && geometry.numOutput == w.size[0] &&
           (params.blobs.size() < 2 || int(params.blobs[1].total()) == w.size[0]);
  }
  static constexpr int kMostInputs = 4;  // colour planes, not a network's inner layers

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    const cv::dnn::MatShape& in = inputs.at(0);
    CV_Assert(in.size() == 4 && in[1] == kernel_.input_channels());
    outputs = {
        {in[0], kernel_.output_channels(), kernel_.output_side(in[2]), kernel_.output_side(in[3])}};
    return false;
  }

  // As the 1x1 stand-in's: the activations, then a depthwise convolution that alone reads the
  // (large) activated output, then the activations after that (PP-OCR's first two layers).
  bool tryFuse(cv::Ptr<cv::dnn::Layer>& top) override {
    return fusion_.try_fuse(top, kernel_.output_channels(), true, activations_, type,
                            "KeyfleetStridedDepthwise");
  }

  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    return fusion_.add_activation(layer, activations_, type);
  }

  void finalize(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays) override {
    fusion_.note_output(inputs_arr, kernel_.output_channels(),
                        [this](int side) { return kernel_.output_side(side); });
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    LayerIo io = float_layer_io(inputs_arr, outputs_arr, false);
    const int h = io.in.size[2], w = io.in.size[3];
    if (!fusion_.fused()) {
      for (int n = 0; n < io.in.size[0]; ++n)
        kernel_.run(io.in.ptr<float>(n), h, w, io.out.ptr<float>(n), activations_.get());
      return;
    }
    fusion_.run(io, kernel_.output_channels(), kernel_.output_side(h), kernel_.output_side(w),
                [&](const float* src, int first, int last, float* band, std::size_t band_plane) {
                  kernel_.run_rows(src, h, w, first, last, band, band_plane, activations_.get());
                });
  }

 private:
  StridedConvolution kernel_;
  ActivationChain activations_;
  DepthwiseFusion fusion_{*this};
};

// The scope's stand-in for a convolution of that geometry, else OpenCV's.
cv::Ptr<cv::dnn::Layer> convolution_stand_in(cv::dnn::LayerParams& params) {
  const DnnLayers& chosen = scope_layers();
  cv::Ptr<cv::dnn::BaseConvolutionLayer> opencv = cv::dnn::ConvolutionLayer::create(params);
  if (chosen.depthwise && DepthwiseLayer::handles(params, *opencv))
    return cv::makePtr<DepthwiseLayer>(params, *opencv);
  if (chosen.pointwise && PointwiseLayer::handles(params, *opencv))
    return chosen.int8_pointwise && Int8PointwiseLayer::pays(params)
               ? cv::Ptr<cv::dnn::Layer>(cv::makePtr<Int8PointwiseLayer>(params))
               : cv::Ptr<cv::dnn::Layer>(cv::makePtr<PointwiseLayer>(params));
  if (chosen.dense_3x3 && Convolution3x3Layer::handles(params, *opencv))
    return cv::makePtr<Convolution3x3Layer>(params);
  if (chosen.dense_3x3 && StridedConvolutionLayer::handles(params, *opencv))
    return cv::makePtr<StridedConvolutionLayer>(params);
  return opencv;
}

// Transposed convolution with stride 2 doubling the plane: 3x3 with padding 1 and output padding 1
// (MiniNet's upsampling) or 2x2 without padding (PP-OCR's DB head), by its four sub-pixel
// convolutions; an activation after it is applied as each plane is done.
class SubpixelDeconvolutionLayer final : public ProductLayer<SubpixelDeconvolution> {
 public:
  explicit SubpixelDeconvolutionLayer(const cv::dnn::LayerParams& params)
      : ProductLayer(params, "KeyfleetSubpixelDeconvolution") {}

  static bool handles(const cv::dnn::LayerParams& params,
                      const cv::dnn::BaseConvolutionLayer& geometry) {
    if (!SubpixelDeconvolution::supported() || params.blobs.empty() || params.blobs[0].dims != 4 ||
        params.blobs[0].type() != CV_32F)
      return false;
    const cv::Mat& w = params.blobs[0];
    // 3x3 with padding 1 and output padding 1, or 2x2 with neither: twice the input either way.
    const bool three = both_are(geometry.kernel_size, 3) && both_are(geometry.pads_begin, 1) &&
                       both_are(geometry.pads_end, 1) && both_are(geometry.adjust_pads, 1);
    const bool two = both_are(geometry.kernel_size, 2) && both_are(geometry.pads_begin, 0) &&
                     both_are(geometry.pads_end, 0) && both_are(geometry.adjust_pads, 0);
    return (three || two) && both_are(geometry.strides, 2) && both_are(geometry.dilations, 1) &&
           geometry.padMode.empty() && params.get<int>("group", 1) == 1 &&
           geometry.numOutput == w.size[1] &&
           (params.blobs.size() < 2 || int(params.blobs[1].total()) == w.size[1]);
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    const cv::dnn::MatShape& in = inputs.at(0);
    CV_Assert(in.size() == 4 && in[1] == kernel_.input_channels());
    outputs = {{in[0], kernel_.output_channels(), 2 * in[2], 2 * in[3]}};
    return false;
  }

  // PP-OCR's DB head: a wide 2x2 layer whose large activated output only a narrow 2x2 layer
  // reads (24 -> 24 -> 1; 7.4 MB at 640x480) takes that one over and runs both a band of rows
  // at a time, as the 1x1 stand-in does with a depthwise layer: the activations, then the narrow
  // layer, then its activations.
  bool tryFuse(cv::Ptr<cv::dnn::Layer>& top) override {
    if (top.empty()) return false;
    if (const auto activation = top.dynamicCast<cv::dnn::ActivationLayer>())
      return setActivation(activation);
    const auto* narrow = dynamic_cast<const SubpixelDeconvolutionLayer*>(top.get());
    if (second_ || !may_pair_ || !narrow || !kernel_.wide_2x2() || !narrow->kernel_.narrow_2x2() ||
        narrow->kernel_.input_channels() != kernel_.output_channels() ||
        output_bytes_ < BandedDepthwise::kSmallestOutputBytes)
      return false;
    if (!order_.runs_next(*this, *top)) return false;
    second_ = top.staticCast<SubpixelDeconvolutionLayer>();
    order_.joined(top->name);
    unfused_type_ = type;
    type = "KeyfleetSubpixelDeconvolutionPair";
    return true;
  }

  // An activation for this layer's chain or, once paired, the narrow layer's (where it runs right
  // after the pair); an empty one (OpenCV's unsetAttached) undoes the pair, as DepthwiseFusion's.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    if (layer.empty()) {
      if (second_) type = unfused_type_;
      second_.release();
      second_activations_.add(layer);
      order_.clear();
      return activations_.add(layer);
    }
    if (second_ && !order_.runs_next(*this, *layer)) return false;
    if (!(second_ ? second_activations_.add(layer) : activations_.add(layer))) return false;
    order_.joined(layer->name);
    return true;
  }

  void finalize(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays) override {
    std::vector<cv::Mat> inputs;
    inputs_arr.getMatVector(inputs);
    if (!inputs.empty() && inputs[0].dims == 4)
      output_bytes_ = std::size_t(kernel_.output_channels()) * 4 * inputs[0].size[2] *
                      std::size_t(inputs[0].size[3]) * sizeof(float);
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    if (!second_) {
      ProductLayer::forward(inputs_arr, outputs_arr, internals_arr);
      return;
    }
    LayerIo io = float_layer_io(inputs_arr, outputs_arr, false);
    const int h = io.in.size[2], w = io.in.size[3], channels = kernel_.output_channels();
    SubpixelDeconvolution& narrow = second_->kernel_;
    CV_Assert(io.out.dims == 4 && io.out.size[1] == narrow.output_channels() &&
              io.out.size[2] == 4 * h && io.out.size[3] == 4 * w);
    // Bands of input rows whose first output (channels planes of 2 rows x 2w a row) takes about
    // 256 KB, as BandedDepthwise's.
    const int rows = std::clamp(int(kPairBandFloats / (std::size_t(channels) * 4 * w)), 1, h);
    band_.resize(std::size_t(channels) * 4 * rows * w);
    const std::size_t out_plane = std::size_t(16) * h * w;
    const FusedOutput out(io.in, io.out, scratch_);
    for (int n = 0; n < io.in.size[0]; ++n)
      for (int y0 = 0; y0 < h; y0 += rows) {
        const int y1 = std::min(h, y0 + rows);
        kernel_.run_2x2_band(io.in.ptr<float>(n), h, w, y0, y1, band_.data(), activations_.get());
        narrow.run_narrow(band_.data(), 2 * (y1 - y0), 2 * w,
                          out.image(n) + std::size_t(4 * y0) * 4 * w, out_plane,
                          second_activations_.get());
      }
    out.apply();
  }

  void run(const float* in, int height, int width, float* out) override {
    kernel_.run(in, height, width, out, activations_.get());
  }

 private:
  static constexpr std::size_t kPairBandFloats = 64 * 1024;
  bool may_pair_ = scope_layers().banded_depthwise;
  std::size_t output_bytes_ = 0;
  std::string unfused_type_;
  FusionOrder order_;  // the narrow layer runs right after this one
  cv::Ptr<SubpixelDeconvolutionLayer> second_;
  ActivationChain second_activations_;
  std::vector<float> band_, scratch_;
};

cv::Ptr<cv::dnn::Layer> deconvolution_stand_in(cv::dnn::LayerParams& params) {
  cv::Ptr<cv::dnn::BaseConvolutionLayer> opencv = cv::dnn::DeconvolutionLayer::create(params);
  if (!SubpixelDeconvolutionLayer::handles(params, *opencv)) return opencv;
  return cv::makePtr<SubpixelDeconvolutionLayer>(params);
}

}  // namespace

cv::Ptr<cv::dnn::Layer> create_convolution(cv::dnn::LayerParams& params) {
  return convolution_stand_in(params);
}

cv::Ptr<cv::dnn::Layer> create_deconvolution(cv::dnn::LayerParams& params) {
  return deconvolution_stand_in(params);
}

}  // namespace keyfleet::vision
