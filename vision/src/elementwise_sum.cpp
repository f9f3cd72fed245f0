// The element-wise sum stand-in (dense_layers.hpp): the FPN's additions in PP-OCR's detector.
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <algorithm>
#include <cctype>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dense_layers.hpp"
#include "opencv_backed_layer.hpp"
#include "pointwise_hand_over.hpp"
#include "upsampling_hand_over.hpp"

namespace keyfleet::vision {

// upsampling_hand_over.hpp: the sums here and the upsampled taps' rows.
void add_floats(const float* a, const float* b, float* dst, int n) {
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

// upsampling_hand_over.hpp: the sums here, the upsamplings and the 1x1 layers' hand-over.
bool planes_contiguous(const cv::Mat& m) {
  return m.dims == 4 && m.type() == CV_32F && m.step[3] == sizeof(float) &&
         m.step[2] == m.step[3] * std::size_t(m.size[3]) &&
         m.step[1] == m.step[2] * std::size_t(m.size[2]);
}

namespace {

// ONNX Add (and Sum) of inputs of one shape: OpenCV 4.6's Eltwise layer adds them in blocks of
// 4,096 values that visit every channel's plane in turn, one element at a time (PP-OCR's detector
// at 640x480 adds two 96 x 120 x 160 maps in its FPN; what that cost and what this saves:
// docs/results/2026-11-28-sums-and-depthwise.md). This one adds whole planes in SIMD, in
// OpenCV's order ((x0 + x1) + x2 ...: the same floats), then applies a fused activation to the
// plane. Anything else (products, maxima, coefficients other than 1, inputs of other shapes or
// channel counts) runs the OpenCV layer this one holds, which also gives the shapes. Of two
// inputs, one may be an upsampling's that waits for this layer (upsampling_hand_over.hpp), and
// one a scaled 1x1 convolution's (pointwise_hand_over.hpp), which this layer then computes with
// the other input added as the convolution's epilogue.
class ElementwiseSumLayer final : public OpenCvBackedLayer<cv::dnn::EltwiseLayer>,
                                  public UpsamplingReader,
                                  public PointwiseReader {
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

  // An empty layer: OpenCV undoes its fusions (before it fuses again), hand-overs included.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    if (layer.empty()) {
      opencv_->setActivation(layer);
      activation_.release();
      hand_overs_.clear();
      return false;
    }
    if (!opencv_->setActivation(layer)) return false;
    activation_ = layer;
    return true;
  }

  void read_upsampling(std::shared_ptr<UpsamplingHandOver> hand_over) override {
    hand_overs_.push_back(std::move(hand_over));
  }

  // At set-up (before OpenCV fuses: not undone with the fusions).
  bool read_pointwise(const std::shared_ptr<PointwiseHandOver>& hand_over) override {
    pointwise_.add(hand_over);
    return true;
  }
  void drop_pointwise(const PointwiseHandOver* hand_over) override { pointwise_.drop(hand_over); }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    const bool ours = outputs.size() == 1 && takes(inputs, outputs[0]);
    if (ours && add_pointwise(inputs, outputs[0])) return;
    for (const cv::Mat& in : inputs)  // written first, as unfused
      if (PointwiseHandOver* waiting = pointwise_.waiting_as(in)) waiting->write_waiting();
    if (ours && add_upsampled(inputs, outputs[0])) return;
    for (const auto& hand_over : hand_overs_)  // upsampled into the waiting blobs, as unfused
      if (hand_over->waiting()) {
        upsample_nearest(hand_over->source, hand_over->target);
        *hand_over = UpsamplingHandOver();
      }
    if (!ours) {
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
        add_floats(inputs[0].ptr<float>(image) + offset, inputs[1].ptr<float>(image) + offset, dst,
                   plane);
        for (std::size_t k = 2; k < inputs.size(); ++k)
          add_floats(dst, inputs[k].ptr<float>(image) + offset, dst, plane);
        if (activation) activation->forwardSlice(dst, dst, plane, plane, channel, channel + 1);
      }
    });
  }

 private:
  // out = a + up(b) where of two inputs the one at `b` is an upsampling's waiting output (its
  // input the hand-over's source) and out does not lie over that source: each source row is
  // widened once into a row of this thread and added to the ky output rows it makes. False, with
  // nothing written, where that is not so.
  bool add_upsampled(const std::vector<cv::Mat>& inputs, cv::Mat& out) {
    if (inputs.size() != 2 || hand_overs_.empty()) return false;
    UpsamplingHandOver* hand_over = nullptr;
    int upsampled = -1;
    for (const auto& h : hand_overs_)
      for (int i = 0; i < 2; ++i)
        if (h->waiting() && inputs[i].data == h->target.data) {
          if (hand_over) return false;  // both inputs waiting
          hand_over = h.get();
          upsampled = i;
        }
    if (!hand_over) return false;
    const cv::Mat& source = hand_over->source;
    if (!upsamples_by_powers_of_two(source, out) || overlaps(source, out)) return false;
    const cv::Mat& other = inputs[1 - upsampled];
    const int channels = out.size[1], h = source.size[2], w = source.size[3];
    const int ky = out.size[2] / h, kx = out.size[3] / w, ow = out.size[3];
    const std::size_t plane = std::size_t(out.size[2]) * ow;
    const cv::dnn::ActivationLayer* activation = activation_.get();
    cv::parallel_for_(cv::Range(0, out.size[0] * channels), [&](const cv::Range& range) {
      std::vector<float> row(ow);
      for (int p = range.start; p < range.end; ++p) {
        const int image = p / channels, channel = p % channels;
        const float* src = source.ptr<float>(image) + std::size_t(channel) * h * w;
        const float* a = other.ptr<float>(image) + channel * plane;
        float* dst = out.ptr<float>(image) + channel * plane;
        for (int y = 0; y < h; ++y) {
          repeat_columns(src + std::size_t(y) * w, w, kx, row.data());
          for (int r = 0; r < ky; ++r) {
            const std::size_t at = (std::size_t(y) * ky + r) * ow;
            // a + b == b + a: OpenCV's floats either way.
            add_floats(a + at, row.data(), dst + at, ow);
          }
        }
        if (activation) activation->forwardSlice(dst, dst, int(plane), plane, channel, channel + 1);
      }
    });
    *hand_over = UpsamplingHandOver();
    return true;
  }

  // out = the waiting scaled convolution + the other input (itself, or an upsampling's waiting
  // output read from its source), one image, no activation: the other input added to each stripe
  // of the convolution's output as it is done. False, with nothing written, where that is not so.
  bool add_pointwise(const std::vector<cv::Mat>& inputs, cv::Mat& out) {
    if (inputs.size() != 2 || activation_ || out.size[0] != 1) return false;
    int mine = 0;
    PointwiseHandOver* waiting = pointwise_.waiting_as(inputs[0]);
    if (!waiting) waiting = pointwise_.waiting_as(inputs[mine = 1]);
    if (!waiting) return false;
    cv::Mat other = inputs[std::size_t(1 - mine)];
    PointwiseHandOver& h = *waiting;
    if (pointwise_.waiting_as(other) || h.kernel->output_channels() != out.size[1] ||
        std::size_t(h.source.size[2]) * h.source.size[3] != out.total() / out.size[1])
      return false;
    UpsamplingHandOver* upsampling = nullptr;
    for (const auto& u : hand_overs_)
      if (u->waiting() && other.data == u->target.data) upsampling = u.get();
    int ky = 1, kx = 1;
    if (upsampling) {
      other = upsampling->source;
      if (!upsamples_by_powers_of_two(other, out) || other.size[0] != 1) return false;
      ky = out.size[2] / other.size[2];
      kx = out.size[3] / other.size[3];
    }
    // The stripes are written before the other input's pixels under them are read.
    if (overlaps(other, out) || other.size[1] != out.size[1]) return false;
    const std::size_t plane = std::size_t(out.size[2]) * out.size[3];
    const ScaledSum sum(h.kernel->output_channels(), h.scales, other, out.size[3], ky, kx);
    h.kernel->run_columns(h.source.ptr<float>(), plane, int(plane), out.ptr<float>(), plane, sum);
    h.target = cv::Mat();
    if (upsampling) *upsampling = UpsamplingHandOver();
    return true;
  }

  static bool overlaps(const cv::Mat& a, const cv::Mat& b) {
    return a.datastart < b.dataend && b.datastart < a.dataend;
  }

  static bool takes(const std::vector<cv::Mat>& inputs, const cv::Mat& out) {
    if (inputs.size() < 2 || !planes_contiguous(out)) return false;
    for (const cv::Mat& in : inputs)
      if (!planes_contiguous(in) || in.size != out.size) return false;
    return true;
  }

  cv::Ptr<cv::dnn::ActivationLayer> activation_;
  std::vector<std::shared_ptr<UpsamplingHandOver>> hand_overs_;
  HeldHandOvers pointwise_;
};

}  // namespace

cv::Ptr<cv::dnn::Layer> create_eltwise(cv::dnn::LayerParams& params) {
  cv::Ptr<cv::dnn::EltwiseLayer> opencv = cv::dnn::EltwiseLayer::create(params);
  if (!ElementwiseSumLayer::handles(params)) return opencv;
  return cv::makePtr<ElementwiseSumLayer>(params, opencv);
}

}  // namespace keyfleet::vision
