#pragma once
// A stand-in layer's one input and one output inside forward(): headers on OpenCV's blobs, checked
// to be float. Internal to keyfleet_vision (dnn_layers.cpp, dense_layers.cpp).
#include <opencv2/core.hpp>

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

}  // namespace keyfleet::vision
