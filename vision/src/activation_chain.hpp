#pragma once
// The chain of activations a stand-in convolution takes over (OpenCV offers each to the layer
// before it) and the element-wise steps it merges them into. Internal to keyfleet_vision
// (dnn_layers.cpp, convolution_layers.cpp).
#include <opencv2/dnn/all_layers.hpp>

#include <vector>

namespace keyfleet::vision {

// dst = scale * hard_swish(src) + shift in one pass, n floats (in place allowed).
void hard_swish_scale_shift_vectorised(const float* src, float* dst, int n, float scale,
                                       float shift);

// dst = scale * src + shift, n floats (in place allowed).
void scale_shift_vectorised(const float* src, float* dst, int n, float scale, float shift);

// Whether `layer` is keyfleet's hard swish stand-in (dnn_layers.cpp): the chain merges the scale
// and shift after one into it.
bool is_hard_swish_stand_in(const cv::dnn::Layer* layer);

// The activations OpenCV fuses into a stand-in, applied in turn to each output plane while it is in
// cache: PP-OCR's layers end in a chain of three (hard swish, then the learnable affine block's
// scale and shift, which OpenCV makes two Power layers), each a pass over memory of its own when
// not fused. Power layers of power 1 after each other become one multiply-add, and that one joins
// the hard swish before it: PP-OCR's chain of three is one pass (the sums rounded once where they
// were rounded two or three times). The first step reads the plane where the layer wrote it, the
// others work in place.
class ActivationChain final : public cv::dnn::ActivationLayer {
 public:
  // Takes `layer` after those it has (OpenCV offers each of a chain in turn); empty clears it.
  bool add(const cv::Ptr<cv::dnn::ActivationLayer>& layer);
  // Null where there is nothing to apply: what the kernels take.
  const cv::dnn::ActivationLayer* get() const { return steps_.empty() ? nullptr : this; }

  void forwardSlice(const float* src, float* dst, int len, size_t plane_size, int cn0,
                    int cn1) const override;

 private:
  struct Step {
    cv::Ptr<cv::dnn::ActivationLayer> layer;  // null: the scale and shift alone
    bool affine;                              // scale and shift after the layer
    float scale, shift;
  };
  std::vector<Step> steps_;
};

}  // namespace keyfleet::vision
