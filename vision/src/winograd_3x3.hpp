#pragma once
// A 3x3 convolution (stride 1, padding 1, one group) by Winograd's minimal filtering F(4x4, 3x3)
// (Lavin and Gray, "Fast Algorithms for Convolutional Neural Networks", 2016): each 4x4 block of
// output pixels is A^T [(G g G^T) . (B^T d B)] A of its 6x6 input patch d, so 36 multiplications
// a block where the direct way takes 144 (F(2x2, 3x3): 64). The 36 element-wise products summed
// over input channels are 36 matrix products (avx2_product.hpp); the transforms run 8 blocks at a
// time in AVX2. Float rounding grows with the transforms' constants (up to 8 and 1/24): outputs
// within about 1e-5 of their spread of the direct sum.
// Float only; internal to keyfleet_vision (convolution_3x3.cpp uses it where it pays).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <algorithm>
#include <vector>

#include "avx2_product.hpp"
#include "product_operands.hpp"

namespace keyfleet::vision {

class Winograd3x3 {
 public:
  // weights: outputs x inputs x 3 x 3, float; bias: empty or one float per output.
  Winograd3x3(const cv::Mat& weights, const cv::Mat& bias);

  // One image: src is input channels planes of h x w, dst output channels planes of h x w, each
  // set contiguous; `activation` (may be null) is applied to each output plane's rows once
  // written. Runs on cv::parallel_for_'s threads. Not reentrant (work buffers).
  void run(const float* src, int h, int w, float* dst, const cv::dnn::ActivationLayer* activation);

 private:
  void pack(ProductBlock block);
  // Blocks [ty0, ty1) of block rows: the transformed input, the products, the outputs.
  void transform_input(const float* src, int h, int w, int ty0, int ty1);
  void multiply(int columns);
  void transform_output(int ty0, int ty1, int h, int w, float* dst,
                        const cv::dnn::ActivationLayer* activation);

  int cin_, cout_;
  static constexpr int kTaps = 36;  // 6 x 6 transformed values a block
  std::vector<float> transformed_;  // [36][cout][cin]: G g G^T of each kernel
  std::vector<float> bias_;
  ProductBlock block_{0, 0};
  int row_blocks_ = 0;
  PackedWeights packed_;
  // The first of the 8 blocks the transforms take from `group` (a multiple of 8) on: where a row
  // holds no whole number of 8, its last 8 overlap the 8 before (computed twice, stored alike).
  int group_start(int group) const { return std::min(group, blocks_across_ - 8); }
  // Per run: the blocks along a row (8 or more); per band: its transform
  // [36][cin][columns_], the products [36][outputs][columns_].
  int blocks_across_ = 0, columns_ = 0;
  std::size_t v_plane_ = 0, m_plane_ = 0;  // between the 36 planes of v_ and of m_
  std::vector<float> v_, m_;
};

}  // namespace keyfleet::vision
