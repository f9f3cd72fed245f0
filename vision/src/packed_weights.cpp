#include "packed_weights.hpp"

#include "bf16_product.hpp"

namespace keyfleet::vision {

std::vector<float> padded_bias(const cv::Mat& bias, int outputs) {
  CV_Assert(bias.empty() || (bias.type() == CV_32F && int(bias.total()) == outputs));
  std::vector<float> padded(std::size_t((outputs + 23) / 24 * 24), 0.f);
  for (int c = 0; c < outputs && !bias.empty(); ++c) padded[c] = bias.ptr<float>()[c];
  return padded;
}

void PackedWeights::pack(ProductBlock block, int taps, int inputs, int outputs, bool bfloat16,
                         const std::function<float(int, int, int)>& weight) {
  const int row_blocks = (outputs + block.rows - 1) / block.rows;
  const int depth = summed_length(inputs, bfloat16);
  const std::size_t size = std::size_t(row_blocks) * taps * depth * block.rows;
  floats.assign(bfloat16 ? 0 : size, 0.f);
  pairs.assign(bfloat16 ? size : 0, 0u);
  for (int co = 0; co < outputs; ++co)
    for (int t = 0; t < taps; ++t)
      for (int k = 0; k < depth; ++k) {
        const std::size_t i =
            ((std::size_t(co / block.rows) * taps + t) * depth + k) * block.rows + co % block.rows;
        if (bfloat16)
          pairs[i] =
              bf16_pair(weight(co, 2 * k, t), 2 * k + 1 < inputs ? weight(co, 2 * k + 1, t) : 0.f);
        else
          floats[i] = weight(co, k, t);
      }
}

}  // namespace keyfleet::vision
