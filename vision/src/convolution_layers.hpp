#pragma once
// keyfleet's stand-ins for OpenCV 4.6's convolutions and transposed convolutions (dnn_layers.hpp
// lists them): the layers that wrap the kernels (depthwise_avx2.hpp, pointwise_convolution.hpp,
// pointwise_int8.hpp, convolution_3x3.hpp, strided_convolution.hpp, subpixel_deconvolution.hpp),
// take over the activations after them and, where one layer alone reads another's large output,
// run the pair a band of rows at a time (banded_depthwise.hpp). Internal to keyfleet_vision
// (dnn_layers.cpp registers them).
#include <opencv2/dnn.hpp>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {

// The stand-ins chosen by the DnnLayersScope alive (dnn_layers.cpp), read as layers are created.
DnnLayers& scope_layers();

// The scope's stand-in for a convolution or transposed convolution of that geometry, else
// OpenCV's own layer.
cv::Ptr<cv::dnn::Layer> create_convolution(cv::dnn::LayerParams& params);
cv::Ptr<cv::dnn::Layer> create_deconvolution(cv::dnn::LayerParams& params);

}  // namespace keyfleet::vision
