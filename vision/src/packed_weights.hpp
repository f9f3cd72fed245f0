#pragma once
// What the product stand-ins (pointwise, sub-pixel and 3x3 convolutions) share: their weights
// laid out for the matrix-product kernels and their bias padded to whole row blocks. Internal to
// keyfleet_vision.
#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <vector>

#include "avx2_product.hpp"

namespace keyfleet::vision {

inline int round_up(int value, int multiple) {
  return (value + multiple - 1) / multiple * multiple;
}

// The summed dimension's length: the input channels, or their pairs in bfloat16.
inline int summed_length(int inputs, bool bfloat16) { return bfloat16 ? (inputs + 1) / 2 : inputs; }

// One float per output, zero where `bias` is empty, padded with zeros to a multiple of 24 (whole
// row blocks of every block shape).
std::vector<float> padded_bias(const cv::Mat& bias, int outputs);

// [row block][tap][summed index][block rows]: floats, or bfloat16 pairs of input channels.
struct PackedWeights {
  std::vector<float> floats;
  std::vector<std::uint32_t> pairs;

  // weight(output, input, tap) for output < outputs, input < inputs, tap < taps.
  void pack(ProductBlock block, int taps, int inputs, int outputs, bool bfloat16,
            const std::function<float(int, int, int)>& weight);
};

}  // namespace keyfleet::vision
