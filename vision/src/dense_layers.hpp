#pragma once
// Stand-ins for two of OpenCV 4.6's layers that end PP-OCR's recogniser (dnn_layers.cpp registers
// them): its inner product (a MatMul by constant weights: 40 time steps x 120 features x 6625
// characters) as the AVX2 matrix product (avx2_product.hpp), about 16 multiply-adds a ns in
// OpenCV's; and the softmax with OpenCV's vectorised exp (cv::hal::exp32f)
// where OpenCV's takes one element at a time. Each returns OpenCV's own layer for what it does not
// take: the inner product where the CPU lacks AVX2 and FMA or where it has no constant weights; the
// softmax (at run time) over another axis or as log-softmax. And the global average pooling of
// squeeze-and-excitation blocks (PP-OCR's detector has ten) summed in SIMD lanes, where OpenCV 4.6
// runs its general pooling loop; other poolings stay OpenCV's. And nearest-neighbour upsampling
// by powers of two (nearest_upsampling.cpp; other resizes stay OpenCV's), and the element-wise
// sum of inputs of one shape (elementwise_sum.cpp; products, maxima and weighted sums stay
// OpenCV's). And the channel scaling x * g of squeeze-and-excitation blocks (channel_scale.cpp),
// which passes on a 1x1 convolution's hand-over (pointwise_hand_over.hpp). Internal to
// keyfleet_vision.
#include <opencv2/dnn.hpp>

namespace keyfleet::vision {

cv::Ptr<cv::dnn::Layer> create_inner_product(cv::dnn::LayerParams& params);
cv::Ptr<cv::dnn::Layer> create_softmax(cv::dnn::LayerParams& params);
cv::Ptr<cv::dnn::Layer> create_pooling(cv::dnn::LayerParams& params);
cv::Ptr<cv::dnn::Layer> create_resize(cv::dnn::LayerParams& params);
cv::Ptr<cv::dnn::Layer> create_eltwise(cv::dnn::LayerParams& params);
cv::Ptr<cv::dnn::Layer> create_scale(cv::dnn::LayerParams& params);

// The mean of n > 0 floats, summed in four vectors of lanes.
float plane_mean(const float* x, int n);

}  // namespace keyfleet::vision
