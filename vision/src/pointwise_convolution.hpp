#pragma once
// A 1x1 convolution (stride 1, no padding, one group) as one matrix product per image through
// avx2_product.hpp, with the activation after it applied to each stripe of columns as soon as it
// is done (still in cache). Internal to keyfleet_vision (dnn_layers.cpp wraps it).
#include <opencv2/core.hpp>
#include <opencv2/dnn/all_layers.hpp>

#include <cstdint>
#include <vector>

#include "avx2_product.hpp"
#include "bf16_product.hpp"
#include "product_operands.hpp"

namespace keyfleet::vision {

// What a caller applies to each finished stripe of a layer's output in place of an activation:
// columns [first, first + n) of every output channel, channel c's at out + c * stride (in a
// buffer or in dst itself; `first` counts from the image's first pixel).
class ColumnsEpilogue {
 public:
  virtual ~ColumnsEpilogue() = default;
  virtual void apply(float* out, std::size_t stride, int first, int n) const = 0;
};

class PointwiseConvolution : public ProductKernel {
 public:
  // weights: output channels x input channels x 1 x 1, float; bias: empty or one per output;
  // bfloat16 as for SubpixelDeconvolution.
  PointwiseConvolution(const cv::Mat& weights, const cv::Mat& bias, bool bfloat16)
      : ProductKernel(weights, bias, bfloat16, 1, false) {}

  // One image: src is input_channels planes of `pixels` floats, dst output_channels planes, each
  // set contiguous; `activation` may be null. Runs on cv::parallel_for_'s threads; not reentrant.
  void run(const float* src, int pixels, float* dst, const cv::dnn::ActivationLayer* activation);

  // Whether run_columns() takes this layer: float products whose row blocks divide the outputs.
  bool runs_columns() const { return !bfloat16_ && cout_ % 2 == 0; }
  // `pixels` columns of one image: src is input_channels planes `src_plane` floats apart, dst
  // output_channels planes `dst_plane` apart (a band of rows of a larger image, say); as run()
  // computes them. Requires runs_columns().
  void run_columns(const float* src, std::size_t src_plane, int pixels, float* dst,
                   std::size_t dst_plane, const cv::dnn::ActivationLayer* activation);
  // The same with `epilogue` applied to each finished stripe instead of an activation.
  void run_columns(const float* src, std::size_t src_plane, int pixels, float* dst,
                   std::size_t dst_plane, const ColumnsEpilogue& epilogue);

  // Output channel c's weights (input_channels() floats) and bias.
  const float* weights_of(int c) const { return weights_.ptr<float>() + std::size_t(c) * cin_; }
  float bias_of(int c) const { return bias_[std::size_t(c)]; }

 private:
  void pack(ProductBlock block);  // the weights for blocks of that shape
  // run_columns's: the weights packed for whole row blocks of `pixels` columns.
  void pack_for_columns(int pixels);
  // Float, the outputs whole row blocks: src and dst used where they are.
  void run_in_place(const float* src, std::size_t src_plane, int pixels, float* dst,
                    std::size_t dst_plane, const cv::dnn::ActivationLayer* activation,
                    const ColumnsEpilogue* epilogue = nullptr);

  // The block shape the weights are packed for (chosen per input size: in float, rows that divide
  // the outputs where a shape's do, else the least padding).
  ProductBlock block_{0, 0};
  int row_blocks_ = 0;
  PackedWeights packed_;
  ProductInput input_;
  // Used when the columns or rows do not fill whole blocks: the products before they go to dst
  // (all of them, or in place only the columns' remainder).
  std::vector<float> products_;
  // In place: the columns' remainder with zero columns after.
  ProductInput tail_input_;
  std::vector<float> tail_input_buffer_;
};

}  // namespace keyfleet::vision
