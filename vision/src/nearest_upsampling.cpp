// The nearest-neighbour Resize stand-in (dense_layers.hpp): FPN upsampling by powers of two.
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <algorithm>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "dense_layers.hpp"
#include "fusion_order.hpp"
#include "opencv_backed_layer.hpp"
#include "upsampling_hand_over.hpp"

namespace keyfleet::vision {
namespace {

bool power_of_two(int k) { return k > 0 && (k & (k - 1)) == 0; }

// repeat_columns for k == K over whole vectors of src: the columns done. K is a constant so that
// the K stores are stores (with k at run time GCC made them a memcpy call every four columns).
template <int K>
int repeat_vectors(const float* src, int n, float* dst) {
  int x = 0;
#if CV_SIMD128
  constexpr int kLanes = cv::v_float32x4::nlanes;
  for (; x + kLanes <= n; x += kLanes) {
    cv::v_float32x4 v[K];
    v[0] = cv::v_load(src + x);
    for (int have = 1; have < K; have *= 2)  // each lane twice, again
      for (int i = have - 1; i >= 0; --i) {
        cv::v_float32x4 lo, hi;
        cv::v_zip(v[i], v[i], lo, hi);
        v[2 * i] = lo;
        v[2 * i + 1] = hi;
      }
    for (int i = 0; i < K; ++i) cv::v_store(dst + std::size_t(x) * K + i * kLanes, v[i]);
  }
#else
  (void)src, (void)n, (void)dst;
#endif
  return x;
}

}  // namespace

void repeat_columns(const float* src, int n, int k, float* dst) {
  int x = 0;
  switch (k) {
    case 1: std::copy_n(src, n, dst); return;
    case 2: x = repeat_vectors<2>(src, n, dst); break;
    case 4: x = repeat_vectors<4>(src, n, dst); break;
    case 8: x = repeat_vectors<8>(src, n, dst); break;
    default: break;
  }
  for (; x < n; ++x) std::fill(dst + std::size_t(x) * k, dst + std::size_t(x + 1) * k, src[x]);
}

bool upsamples_by_powers_of_two(const cv::Mat& in, const cv::Mat& out) {
  if (in.dims != 4 || in.type() != CV_32F || !planes_contiguous(out) || !in.isContinuous() ||
      in.size[0] != out.size[0] || in.size[1] != out.size[1] || in.size[2] <= 0 || in.size[3] <= 0)
    return false;
  return out.size[2] % in.size[2] == 0 && out.size[3] % in.size[3] == 0 &&
         power_of_two(out.size[2] / in.size[2]) && power_of_two(out.size[3] / in.size[3]);
}

void upsample_nearest(const cv::Mat& in, cv::Mat& out) {
  const int channels = in.size[1], h = in.size[2], w = in.size[3];
  const int ky = out.size[2] / h, kx = out.size[3] / w, ow = out.size[3];
  cv::parallel_for_(cv::Range(0, in.size[0] * channels), [&](const cv::Range& range) {
    for (int p = range.start; p < range.end; ++p) {
      // Images apart: the output may be a slice of a concatenation's channels.
      const int image = p / channels, channel = p % channels;
      const float* src = in.ptr<float>(image) + std::size_t(channel) * h * w;
      float* dst = out.ptr<float>(image) + std::size_t(channel) * out.size[2] * ow;
      for (int y = 0; y < h; ++y) {
        float* row = dst + std::size_t(y) * ky * ow;
        repeat_columns(src + std::size_t(y) * w, w, kx, row);
        for (int r = 1; r < ky; ++r)
          std::memcpy(row + std::size_t(r) * ow, row, sizeof(float) * std::size_t(ow));
      }
    }
  });
}

namespace {

// ONNX Resize in "nearest" mode (asymmetric coordinates, floor), which OpenCV 4.6 computes one
// element at a time with a float product and a conversion each (PP-OCR's detector has six, its
// neck's upsamplings by 2, 4 and 8; 1.9 ms of a 320x256 pass on an AMD EPYC). Where the output's
// sides are the input's times powers of two, source (y, x) of output (y, x) is (y / ky, x / kx)
// exactly, as in OpenCV's arithmetic: each input row is widened once and copied ky times.
// Any other geometry (and every other mode) runs the OpenCV layer this one holds, which also
// gives the shapes. Where its only reader is a sum stand-in that runs right after it, or a
// concatenation that only a 3x3 convolution stand-in reads, it hands that layer its input instead
// (upsampling_hand_over.hpp).
class NearestUpsamplingLayer final : public OpenCvBackedLayer<cv::dnn::Layer> {
 public:
  NearestUpsamplingLayer(const cv::dnn::LayerParams& params, cv::Ptr<cv::dnn::Layer> opencv)
      : OpenCvBackedLayer(params, std::move(opencv), "KeyfleetNearestUpsampling") {}

  static bool handles(const cv::dnn::LayerParams& params) {
    return params.get<cv::String>("interpolation", "") == "nearest" &&
           !params.get<bool>("align_corners", false) &&
           !params.get<bool>("half_pixel_centers", false);
  }

  // OpenCV offers the layer that alone reads this one's output: a sum stand-in running right
  // after it takes the hand-over; so does a 3x3 convolution stand-in that alone reads the
  // concatenation this one writes a slice of, where this one upsamples by kTapsFromFactor or more
  // each way. Nothing is fused in OpenCV's sense (the layers keep their blobs and their turns), so
  // this returns false either way.
  bool tryFuse(cv::Ptr<cv::dnn::Layer>& top) override {
    auto* reader = dynamic_cast<UpsamplingReader*>(top.get());
    if (reader && order_.runs_next(*this, *top)) {
      hand_over_ = std::make_shared<UpsamplingHandOver>();
      reader->read_upsampling(hand_over_);
      type = "KeyfleetNearestUpsamplingIntoSum";
    } else if (top && top->type == "Concat" && ky_ >= kTapsFromFactor && kx_ >= kTapsFromFactor) {
      auto* convolution = dynamic_cast<SliceReader*>(order_.sole_reader(*top).get());
      auto hand_over = std::make_shared<UpsamplingHandOver>();
      if (convolution && convolution->read_upsampled_slice(hand_over)) {
        slice_hand_over_ = std::move(hand_over);
        type = "KeyfleetNearestUpsamplingIntoConvolution";
      }
    }
    return false;
  }

  // The factors of this set-up (OpenCV finalises a layer before it fuses).
  void finalize(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr) override {
    OpenCvBackedLayer::finalize(inputs_arr, outputs_arr);
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    ky_ = kx_ = 0;
    if (inputs.size() == 1 && outputs.size() == 1 && inputs[0].dims == 4 && outputs[0].dims == 4 &&
        inputs[0].size[2] > 0 && inputs[0].size[3] > 0 &&
        outputs[0].size[2] % inputs[0].size[2] == 0 &&
        outputs[0].size[3] % inputs[0].size[3] == 0) {
      ky_ = outputs[0].size[2] / inputs[0].size[2];
      kx_ = outputs[0].size[3] / inputs[0].size[3];
    }
  }

  // OpenCV undoes its fusions (an empty layer) before it fuses again: so are the hand-overs.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override {
    if (layer.empty()) {
      hand_over_.reset();
      slice_hand_over_.reset();
      type = "KeyfleetNearestUpsampling";
    }
    return false;
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    const cv::Mat& in = inputs.at(0);
    cv::Mat& out = outputs.at(0);
    if (!upsamples_by_powers_of_two(in, out)) {
      opencv_->forward(inputs_arr, outputs_arr, internals_arr);
      return;
    }
    if (hand_over_) {
      *hand_over_ = {in, out};
      return;
    }
    // A slice of the concatenation's output (OpenCV fused the concatenation: nothing copies the
    // slice before the convolution reads it), of one image, at a factor the convolution takes.
    const bool slice =
        out.datastart != out.data || out.dataend != out.data + out.total() * out.elemSize();
    if (slice_hand_over_ && slice && in.size[0] == 1 &&
        out.size[2] >= kTapsFromFactor * in.size[2] &&
        out.size[3] >= kTapsFromFactor * in.size[3]) {
      in.copyTo(slice_hand_over_->source);  // OpenCV may lay another blob over `in` before then
      slice_hand_over_->target = out;
      return;
    }
    upsample_nearest(in, out);
  }

 private:
  FusionOrder order_;  // the sum runs right after this layer
  std::shared_ptr<UpsamplingHandOver> hand_over_;
  std::shared_ptr<UpsamplingHandOver> slice_hand_over_;  // to a convolution
  int ky_ = 0, kx_ = 0;                                  // this set-up's factors
};

}  // namespace

cv::Ptr<cv::dnn::Layer> create_resize(cv::dnn::LayerParams& params) {
  cv::Ptr<cv::dnn::Layer> opencv = cv::dnn::ResizeLayer::create(params);
  if (!NearestUpsamplingLayer::handles(params)) return opencv;
  return cv::makePtr<NearestUpsamplingLayer>(params, opencv);
}

}  // namespace keyfleet::vision
