#include "dense_layers.hpp"

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/dnn/shape_utils.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "avx2_product.hpp"
#include "layer_io.hpp"
#include "pointwise_hand_over.hpp"
#include "product_operands.hpp"

namespace keyfleet::vision {

float plane_mean(const float* x, int n) {
  constexpr int kLanes = cv::v_float32::nlanes;
  cv::v_float32 s0 = cv::vx_setzero_f32(), s1 = s0, s2 = s0, s3 = s0;
  int i = 0;
  for (; i + 4 * kLanes <= n; i += 4 * kLanes) {
    s0 += cv::vx_load(x + i);
    s1 += cv::vx_load(x + i + kLanes);
    s2 += cv::vx_load(x + i + 2 * kLanes);
    s3 += cv::vx_load(x + i + 3 * kLanes);
  }
  float sum = cv::v_reduce_sum((s0 + s1) + (s2 + s3));
  for (; i < n; ++i) sum += x[i];
  return sum / float(n);
}

namespace {

int normalised_axis(int axis, int dims) { return axis < 0 ? axis + dims : axis; }

// y[m][n] = bias[n] + sum over k of x[m][k] w[n][k], m over the input's dimensions before the
// axis, k over the rest: as OpenCV's InnerProduct with constant weights (num_output x K).
class InnerProductLayer final : public cv::dnn::Layer {
 public:
  explicit InnerProductLayer(const cv::dnn::LayerParams& params)
      : axis_(params.get<int>("axis", 1)), outputs_(params.get<int>("num_output")) {
    setParamsFrom(params);
    type = "KeyfleetInnerProduct";
    weights_ = blobs[0].reshape(1, outputs_);  // num_output x K
    if (params.get<bool>("bias_term", true) && blobs.size() > 1) bias_ = blobs[1].reshape(1, 1);
  }

  static bool handles(const cv::dnn::LayerParams& params) {
    if (!product_supported() || params.blobs.empty() || params.blobs.size() > 2) return false;
    // With constant weights OpenCV multiplies by them as num_output x K whatever transB says (the
    // importer has laid them out so); transA would be the input's, which it does not take here.
    if (params.get<bool>("transA", false)) return false;
    const cv::Mat& w = params.blobs[0];
    const int outputs = params.get<int>("num_output", 0);
    const bool bias = params.get<bool>("bias_term", true);
    return w.type() == CV_32F && w.isContinuous() && outputs > 0 && w.dims >= 2 &&
           w.total() % std::size_t(outputs) == 0 &&
           (!bias || (params.blobs.size() == 2 && params.blobs[1].type() == CV_32F &&
                      params.blobs[1].total() == std::size_t(outputs)));
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    CV_Assert(inputs.size() == 1);
    const int axis = normalised_axis(axis_, int(inputs[0].size()));
    CV_Assert(axis >= 0 && axis < int(inputs[0].size()) &&
              cv::dnn::total(inputs[0], axis) == weights_.cols);
    cv::dnn::MatShape shape(inputs[0].begin(), inputs[0].begin() + axis);
    shape.push_back(outputs_);
    outputs = {shape};
    return false;
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    LayerIo io = float_layer_io(inputs_arr, outputs_arr);
    const cv::Mat& in = io.in;
    cv::Mat& out = io.out;
    const int axis = normalised_axis(axis_, in.dims);
    const int rows = cv::dnn::total(cv::dnn::shape(in), 0, axis), depth = weights_.cols;
    const ProductBlock block = float_product_block(rows, outputs_);
    if (block.columns != packed_block_.columns) transpose_weights(block.columns);
    packed_block_ = block;
    const int row_blocks = (rows + block.rows - 1) / block.rows;
    const int columns = round_up(outputs_, block.columns);
    // The input as the kernel's left operand, laid out as the convolutions' weights are (one
    // tap; zero past the rows).
    const float* x = in.ptr<float>();
    input_.pack(block, 1, depth, rows, false,
                [&](int m, int k, int) { return x[std::size_t(m) * depth + k]; });
    // The products start from the bias (zero past the outputs).
    products_.assign(std::size_t(row_blocks) * block.rows * columns, 0.f);
    for (int m = 0; m < row_blocks * block.rows && !bias_.empty(); ++m)
      std::copy_n(bias_.ptr<float>(), outputs_, products_.data() + std::size_t(m) * columns);
    const int chunk = summed_chunk(depth, 1, block.columns), zero_shift = 0;
    cv::parallel_for_(cv::Range(0, columns / block.columns), [&](const cv::Range& range) {
      for (int cb = range.start; cb < range.end; ++cb)
        for (int k0 = 0; k0 < depth; k0 += chunk)
          for (int rb = 0; rb < row_blocks; ++rb) {
            const int n0 = cb * block.columns;
            product_block(block, 1,
                          input_.floats.data() + (std::size_t(rb) * depth + k0) * block.rows, 0,
                          transposed_.data() + std::size_t(k0) * columns + n0, &zero_shift,
                          std::min(chunk, depth - k0), std::size_t(columns), nullptr,
                          products_.data() + std::size_t(rb) * block.rows * columns + n0,
                          std::size_t(columns));
          }
    });
    float* y = out.ptr<float>();
    for (int m = 0; m < rows; ++m)
      std::copy_n(products_.data() + std::size_t(m) * columns, outputs_,
                  y + std::size_t(m) * outputs_);
  }

 private:
  // The weights as the kernel's right operand: K rows of num_output columns, padded with zeros
  // to whole blocks of `block_columns`.
  void transpose_weights(int block_columns) {
    const int depth = weights_.cols, columns = round_up(outputs_, block_columns);
    transposed_.assign(std::size_t(depth) * columns, 0.f);
    for (int n = 0; n < outputs_; ++n)
      for (int k = 0; k < depth; ++k)
        transposed_[std::size_t(k) * columns + n] = weights_.at<float>(n, k);
  }

  int axis_, outputs_;
  cv::Mat weights_, bias_;
  ProductBlock packed_block_{0, 0};
  PackedWeights input_;
  std::vector<float> transposed_, products_;
};

// Softmax (or log-softmax) over one axis: the maximum taken out, OpenCV's vectorised exp, the
// sum divided out (or its log subtracted), the positions after the axis side by side in vectors.
class SoftmaxLayer final : public cv::dnn::Layer {
 public:
  explicit SoftmaxLayer(const cv::dnn::LayerParams& params)
      : axis_(params.get<int>("axis", 1)), log_(params.get<bool>("log_softmax", false)) {
    setParamsFrom(params);
    type = "KeyfleetSoftmax";
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    CV_Assert(inputs.size() == 1);
    const int axis = normalised_axis(axis_, int(inputs[0].size()));
    CV_Assert(axis >= 0 && axis < int(inputs[0].size()));
    outputs = {inputs[0]};
    return true;  // may run in place
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    LayerIo io = float_layer_io(inputs_arr, outputs_arr);
    const cv::Mat& in = io.in;
    cv::Mat& out = io.out;
    CV_Assert(in.total() == out.total());
    const int axis = normalised_axis(axis_, in.dims);
    const int outer = cv::dnn::total(cv::dnn::shape(in), 0, axis), length = in.size[axis],
              inner = cv::dnn::total(cv::dnn::shape(in), axis + 1);
    const std::size_t slice = std::size_t(length) * inner;
    cv::parallel_for_(cv::Range(0, outer), [&](const cv::Range& range) {
      std::vector<float> top(static_cast<std::size_t>(inner)), sum(top.size());
      for (int o = range.start; o < range.end; ++o)
        if (inner == 1)
          softmax_row(in.ptr<float>() + o * slice, out.ptr<float>() + o * slice, length);
        else
          softmax_slice(in.ptr<float>() + o * slice, out.ptr<float>() + o * slice, length, inner,
                        top.data(), sum.data());
    });
  }

 private:
  // One softmax over n contiguous floats.
  void softmax_row(const float* src, float* dst, int n) const {
    constexpr int kLanes = cv::v_float32::nlanes;
    cv::v_float32 vmax = cv::vx_setall_f32(-std::numeric_limits<float>::infinity());
    int i = 0;
    for (; i + kLanes <= n; i += kLanes) vmax = cv::v_max(vmax, cv::vx_load(src + i));
    float top = cv::v_reduce_max(vmax);
    for (; i < n; ++i) top = std::max(top, src[i]);
    const cv::v_float32 shift = cv::vx_setall_f32(top);
    for (i = 0; i + kLanes <= n; i += kLanes) cv::v_store(dst + i, cv::vx_load(src + i) - shift);
    for (; i < n; ++i) dst[i] = src[i] - top;
    if (log_) {
      std::vector<float> e(dst, dst + n);
      cv::hal::exp32f(e.data(), e.data(), n);
      float sum = 0.f;
      for (const float v : e) sum += v;
      const float log_sum = std::log(sum);
      for (i = 0; i < n; ++i) dst[i] -= log_sum;
      return;
    }
    cv::hal::exp32f(dst, dst, n);
    cv::v_float32 vsum = cv::vx_setzero_f32();
    for (i = 0; i + kLanes <= n; i += kLanes) vsum += cv::vx_load(dst + i);
    float sum = cv::v_reduce_sum(vsum);
    for (; i < n; ++i) sum += dst[i];
    const float inverse = 1.f / sum;
    const cv::v_float32 scale = cv::vx_setall_f32(inverse);
    for (i = 0; i + kLanes <= n; i += kLanes) cv::v_store(dst + i, cv::vx_load(dst + i) * scale);
    for (; i < n; ++i) dst[i] *= inverse;
  }

  // src, dst: `length` rows of `inner` floats; each column is one softmax.
  void softmax_slice(const float* src, float* dst, int length, int inner, float* top,
                     float* sum) const {
    constexpr int kLanes = cv::v_float32::nlanes;
    const auto each = [inner](const auto& vector_op, const auto& scalar_op) {
      int i = 0;
      for (; i + kLanes <= inner; i += kLanes) vector_op(i);
      for (; i < inner; ++i) scalar_op(i);
    };
    std::copy_n(src, inner, top);
    for (int c = 1; c < length; ++c) {
      const float* row = src + std::size_t(c) * inner;
      each(
          [&](int i) {
            cv::v_store(top + i, cv::v_max(cv::vx_load(top + i), cv::vx_load(row + i)));
          },
          [&](int i) { top[i] = std::max(top[i], row[i]); });
    }
    std::fill(sum, sum + inner, 0.f);
    for (int c = 0; c < length; ++c) {
      const float* from = src + std::size_t(c) * inner;
      float* row = dst + std::size_t(c) * inner;
      each([&](int i) { cv::v_store(row + i, cv::vx_load(from + i) - cv::vx_load(top + i)); },
           [&](int i) { row[i] = from[i] - top[i]; });
      if (log_) {
        std::vector<float> e(row, row + inner);
        cv::hal::exp32f(e.data(), e.data(), inner);
        for (int i = 0; i < inner; ++i) sum[i] += e[std::size_t(i)];
        continue;
      }
      cv::hal::exp32f(row, row, inner);
      each([&](int i) { cv::v_store(sum + i, cv::vx_load(sum + i) + cv::vx_load(row + i)); },
           [&](int i) { sum[i] += row[i]; });
    }
    if (log_) {
      cv::hal::log32f(sum, sum, inner);
      for (int c = 0; c < length; ++c) {
        float* row = dst + std::size_t(c) * inner;
        for (int i = 0; i < inner; ++i) row[i] -= sum[i];
      }
      return;
    }
    for (int i = 0; i < inner; ++i) sum[i] = 1.f / sum[i];
    for (int c = 0; c < length; ++c) {
      float* row = dst + std::size_t(c) * inner;
      each([&](int i) { cv::v_store(row + i, cv::vx_load(row + i) * cv::vx_load(sum + i)); },
           [&](int i) { row[i] *= sum[i]; });
    }
  }

  int axis_;
  bool log_;
};

// Global average pooling: each N x C plane's mean (planes of any number of dimensions). Where its
// input is a 1x1 convolution's output left unwritten (pointwise_hand_over.hpp), the means come
// from the convolution's input.
class GlobalAveragePoolLayer final : public cv::dnn::Layer, public PointwiseReader {
 public:
  explicit GlobalAveragePoolLayer(const cv::dnn::LayerParams& params) {
    setParamsFrom(params);
    type = "KeyfleetGlobalAveragePool";
  }

  static bool handles(const cv::dnn::LayerParams& params) {
    return params.get<bool>("global_pooling", false) && !params.has("axes") &&
           cv::toLowerCase(params.get<cv::String>("pool", "max")) == "ave";
  }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, int,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    CV_Assert(inputs.size() == 1 && inputs[0].size() >= 3);
    cv::dnn::MatShape out = inputs[0];  // N x C x 1 x ... (every spatial side 1)
    std::fill(out.begin() + 2, out.end(), 1);
    outputs = {out};
    return false;
  }

  bool read_pointwise(const std::shared_ptr<PointwiseHandOver>& hand_over) override {
    held_.add(hand_over);
    return true;
  }
  void drop_pointwise(const PointwiseHandOver* hand_over) override { held_.drop(hand_over); }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays) override {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    const cv::Mat& in = inputs.at(0);
    cv::Mat& out = outputs.at(0);
    CV_Assert(in.type() == CV_32F && in.isContinuous() && out.isContinuous() && in.dims >= 3);
    if (PointwiseHandOver* hand_over = held_.waiting_as(in)) {
      if (in.size[0] == 1 && int(out.total()) == hand_over->kernel->output_channels()) {
        hand_over->means(out.ptr<float>());
        return;
      }
      hand_over->write_waiting();
    }
    const int planes = in.size[0] * in.size[1];
    const int n = planes == 0 ? 0 : int(in.total() / std::size_t(planes));
    if (n == 0) {
      out.setTo(0);  // no pixels: what OpenCV's pooling gives an empty plane
      return;
    }
    cv::parallel_for_(cv::Range(0, planes), [&](const cv::Range& range) {
      for (int p = range.start; p < range.end; ++p)
        out.ptr<float>()[p] = plane_mean(in.ptr<float>() + std::size_t(p) * std::size_t(n), n);
    });
  }

 private:
  HeldHandOvers held_;
};

}  // namespace

cv::Ptr<cv::dnn::Layer> create_pooling(cv::dnn::LayerParams& params) {
  if (!GlobalAveragePoolLayer::handles(params)) return cv::dnn::PoolingLayer::create(params);
  return cv::makePtr<GlobalAveragePoolLayer>(params);
}

cv::Ptr<cv::dnn::Layer> create_inner_product(cv::dnn::LayerParams& params) {
  if (!InnerProductLayer::handles(params)) return cv::dnn::InnerProductLayer::create(params);
  return cv::makePtr<InnerProductLayer>(params);
}

cv::Ptr<cv::dnn::Layer> create_softmax(cv::dnn::LayerParams& params) {
  return cv::makePtr<SoftmaxLayer>(params);
}

}  // namespace keyfleet::vision
