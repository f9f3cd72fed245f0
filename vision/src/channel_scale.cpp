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

  bool read_pointwise(const std::shared_ptr<PointwiseHandOver>& hand_over) override {
    received_.add(hand_over);
    return true;
  }
  void drop_pointwise(const PointwiseHandOver* hand_over) override {
    received_.drop(hand_over);
    withdraw_from(order_.readers(*this), hand_over);
  }
  bool scales_channels() const override { return true; }

  void finalize(cv::InputArrayOfArrays inputs, cv::OutputArrayOfArrays outputs) override {
    OpenCvBackedLayer::finalize(inputs, outputs);
    // The convolution before it (a lower id) has handed over, or not, by now: passed on where
    // every reader of this output takes it.
    const std::vector<cv::Ptr<cv::dnn::Layer>> readers = order_.readers(*this);
    passes_on_ = !received_.all().empty();
    for (const auto& hand_over : received_.all())
      if (passes_on_ && !hand_over_to(readers, hand_over)) passes_on_ = false;
    if (!passes_on_)
      for (const auto& hand_over : received_.all()) withdraw_from(readers, hand_over.get());
    type = passes_on_ ? "KeyfleetScaleHandedOver" : "KeyfleetScale";
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays internals_arr) override {
    if (!received_.all().empty() && take(inputs_arr, outputs_arr)) return;
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
    int x = 0;
    PointwiseHandOver* hand_over = received_.waiting_as(inputs[0]);
    if (!hand_over) hand_over = received_.waiting_as(inputs[x = 1]);
    if (!hand_over) return false;
    const cv::Mat& s = inputs[std::size_t(1 - x)];
    const int channels = hand_over->kernel->output_channels();
    if (inputs[std::size_t(x)].size[0] != 1 || s.type() != CV_32F || !s.isContinuous() ||
        int(s.total()) != channels || (s.dims > 1 && s.size[1] != channels) ||
        outputs[0].size != inputs[std::size_t(x)].size) {
      hand_over->write_waiting();
      return false;
    }
    std::vector<float>& scales = hand_over->scales;
    if (scales.empty()) scales.assign(std::size_t(channels), 1.f);
    for (int c = 0; c < channels; ++c) scales[std::size_t(c)] *= s.ptr<float>()[c];
    hand_over->target = outputs[0];
    if (!passes_on_) hand_over->write_waiting();
    return true;
  }

  HeldHandOvers received_;
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
