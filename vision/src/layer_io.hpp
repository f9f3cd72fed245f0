#pragma once
// A stand-in layer's one input and one output inside forward(): headers on OpenCV's blobs, checked
// to be float. Internal to keyfleet_vision (dnn_layers.cpp, dense_layers.cpp).
#include <opencv2/core.hpp>

#include <algorithm>
#include <vector>

namespace keyfleet::vision {

struct LayerIo {
  cv::Mat in, out;
};

// The input continuous; the output too where `continuous_output` (a layer whose output may be a
// slice of a concatenation says false and keeps images apart itself).
inline LayerIo float_layer_io(cv::InputArrayOfArrays inputs_arr,
                              cv::OutputArrayOfArrays outputs_arr, bool continuous_output = true) {
  std::vector<cv::Mat> inputs, outputs;
  inputs_arr.getMatVector(inputs);
  outputs_arr.getMatVector(outputs);
  LayerIo io{inputs.at(0), outputs.at(0)};
  CV_Assert(io.in.type() == CV_32F && io.in.isContinuous() && io.out.type() == CV_32F &&
            (!continuous_output || io.out.isContinuous()));
  return io;
}

// Where a fused layer writes its output. OpenCV lays the blobs out before it fuses layers, so the
// output (the last fused layer's) may take memory the first layer's input holds: in the unfused
// order that input is dead by then, but a fused layer computing band by band still reads it.
// Where the two overlap, `scratch` (resized) is written instead and apply() copies it back.
// The fused layers also run one right after the other in OpenCV's order: the stand-ins fuse no
// pair with a layer of another branch between them (fusion_order.hpp).
class FusedOutput {
 public:
  FusedOutput(const cv::Mat& in, cv::Mat& out, std::vector<float>& scratch)
      : out_(out), per_image_(out.total() / std::size_t(out.size[0])) {
    overlap_ = in.datastart < out.dataend && out.datastart < in.dataend;
    if (overlap_) scratch.resize(out.total());
    scratch_ = overlap_ ? scratch.data() : nullptr;
  }
  // Image n's planes, contiguous (a slice of a concatenation keeps its images apart).
  float* image(int n) const {
    return overlap_ ? scratch_ + std::size_t(n) * per_image_ : out_.ptr<float>(n);
  }
  void apply() const {
    if (!overlap_) return;
    for (int n = 0; n < out_.size[0]; ++n)
      std::copy_n(scratch_ + std::size_t(n) * per_image_, per_image_, out_.ptr<float>(n));
  }

 private:
  cv::Mat& out_;
  std::size_t per_image_;
  bool overlap_;
  float* scratch_;
};

}  // namespace keyfleet::vision
