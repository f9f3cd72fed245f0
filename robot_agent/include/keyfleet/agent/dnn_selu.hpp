#pragma once
// A SELU for OpenCV DNN with a vectorised exp. OpenCV 4.6 computes SELU one element at a time
// with std::exp (about 10 ns an element here, a quarter of MiniNet's forward pass on one thread);
// this layer computes the same function (to float rounding) with cv::hal::exp32f, about 1 ns. It
// derives from ActivationLayer, so OpenCV still fuses it into the convolution or sum before it.
#include <opencv2/dnn.hpp>

namespace keyfleet::agent {

// selu(x) = gamma * (max(x, 0) + alpha * (exp(min(x, 0)) - 1)), for n floats (in place allowed).
void selu_vectorised(const float* src, float* dst, int n, float alpha, float gamma);

// While alive, networks whose layers are created (on their first forward pass) get this SELU
// for ONNX "Selu" nodes instead of OpenCV's. OpenCV's layer registry is process-wide: keep the
// scope to the construction of one network (instances already created keep their class). One
// scope at a time in a process: a second one waits for the first to end.
class VectorisedSeluScope {
 public:
  VectorisedSeluScope();
  ~VectorisedSeluScope();
  VectorisedSeluScope(const VectorisedSeluScope&) = delete;
  VectorisedSeluScope& operator=(const VectorisedSeluScope&) = delete;
};

}  // namespace keyfleet::agent
