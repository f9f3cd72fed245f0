// The channel scaling stand-in (dense_layers.hpp): x * s where s holds one float per channel of x,
// what OpenCV's importer makes of an ONNX Mul by an N x C x 1 x 1 tensor (PP-OCR's RSE layers:
// x * (g + 1), g a squeeze-and-excitation gate).
#include <opencv2/dnn/all_layers.hpp>

#include <memory>
#include <utility>
#include <vector>

#include "dense_layers.hpp"
#include "fusion_order.hpp"
#include "opencv_backed_layer.hpp"
#include "pointwise_hand_over.hpp"

namespace keyfleet::vision {
namespace {

// OpenCV's Scale layer with two inputs, which it runs for everything but one case: where x is a
// 1x1 convolution's output left unwritten (pointwise_hand_over.hpp), s joins the hand-over and,
// where every reader of this layer's output takes the hand-over in turn, the output is left
// unwritten too; else this layer writes the scaled convolution itself, x never written.
class ChannelScaleLayer final : public OpenCvBackedLayer<cv::dnn::ScaleLayer>,
                                public PointwiseReader {
 public:
  ChannelScaleLayer(const cv::dnn::LayerParams& params, cv::Ptr<cv::dnn::ScaleLayer> opencv)
      : OpenCvBackedLayer(params, std::move(opencv), "KeyfleetScale") {}

  bool read_pointwise(std::shared_ptr<PointwiseHandOver> hand_over) override {
    hand_over_ = std::move(hand_over);
    return true;
  }

  void finalize(cv::InputArrayOfArrays inputs, cv::OutputArrayOfArrays outputs) override {
    OpenCvBackedLayer::finalize(inputs, outputs);
    // The convolution before it (a lower id) has handed over, or not, by now.
    const bool handed = hand_over_ != nullptr;
    passes_on_ = hand_over_to(order_.readers(*this), hand_over_) && handed;
    type = passes_on_ ? "KeyfleetScaleHandedOver" : "KeyfleetScale";
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    if (hand_over_ && take(inputs_arr, outputs_arr)) return;
    opencv_->forward(inputs_arr, outputs_arr, internals_arr);
  }

 private:
  // x * s from the hand-over where one input is its waiting blob; else, where one is, that
  // blob written first (false: OpenCV's layer runs as unfused).
  bool take(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr) {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    if (inputs.size() != 2 || outputs.size() != 1) return false;
    const int x = hand_over_->is(inputs[0]) ? 0 : hand_over_->is(inputs[1]) ? 1 : -1;
    if (x < 0) return false;
    const cv::Mat& s = inputs[std::size_t(1 - x)];
    const int channels = hand_over_->kernel->output_channels();
    if (inputs[std::size_t(x)].size[0] != 1 || s.type() != CV_32F || !s.isContinuous() ||
        int(s.total()) != channels || (s.dims > 1 && s.size[1] != channels) ||
        outputs[0].size != inputs[std::size_t(x)].size) {
      hand_over_->write_waiting();
      return false;
    }
    std::vector<float>& scales = hand_over_->scales;
    if (scales.empty()) scales.assign(std::size_t(channels), 1.f);
    for (int c = 0; c < channels; ++c) scales[std::size_t(c)] *= s.ptr<float>()[c];
    hand_over_->target = outputs[0];
    if (!passes_on_) hand_over_->write_waiting();
    return true;
  }

  std::shared_ptr<PointwiseHandOver> hand_over_;
  bool passes_on_ = false;
  FusionOrder order_;  // its readers, found in the watched network
};

}  // namespace

cv::Ptr<cv::dnn::Layer> create_scale(cv::dnn::LayerParams& params) {
  cv::Ptr<cv::dnn::ScaleLayer> opencv = cv::dnn::ScaleLayer::create(params);
  if (!params.blobs.empty()) return opencv;  // constant scales: OpenCV's (its fusions read them)
  return cv::makePtr<ChannelScaleLayer>(params, opencv);
}

}  // namespace keyfleet::vision
