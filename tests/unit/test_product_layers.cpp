// keyfleet's stand-in layers (dnn_layers.hpp) compute what OpenCV's layers do: the sub-pixel
// transposed convolution for the geometries it takes over (3x3, stride 2, padding 1, output
// padding 1; 2x2, stride 2, no padding), the 1x1 convolution, the dense 3x3 one (Winograd's in
// float), the stride-2 first layer, the depthwise one, with and without bias and a fused chain of
// activations; in float, and in bfloat16 where the CPU has it (then what OpenCV computes from the
// input and weights rounded to bfloat16); the 1x1 one in int8 (the quantized product, near
// OpenCV's); Power, Sigmoid, the inner product, softmax, global average pooling, nearest
// upsampling and the element-wise sum; other geometries stay OpenCV's, and the shipped MiniNet
// gives the same masks in a batch as one frame at a time.
#include <gtest/gtest.h>

#include <opencv2/dnn/shape_utils.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <tuple>
#include <typeinfo>
#include <vector>

#include "keyfleet/vision/cpu_class.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/text_segmenter.hpp"

namespace keyfleet::vision {
namespace {

struct Geometry {
  int kernel = 3, stride = 2, pad = 1, adjust = 1;
};

// A net of the one layer `params` (named "layer"), then a layer of type `then` where given,
// through OpenCV DNN with or without keyfleet's stand-ins; `type`: the type of the layer that ran
// `params`, `class_name`: its C++ class (a stand-in may keep OpenCV's type name).
cv::Mat run_one_layer(cv::dnn::LayerParams params, const cv::Mat& input, DnnLayers layers,
                      std::string* type, const char* then = nullptr,
                      std::string* class_name = nullptr) {
  params.name = "layer";
  std::optional<DnnLayersScope> scope;
  if (layers.any()) scope.emplace(layers);
  cv::dnn::Net net;
  net.addLayerToPrev(params.name, params.type, params);
  if (then) {
    cv::dnn::LayerParams next;
    next.type = next.name = then;
    net.addLayerToPrev(next.name, next.type, next);
  }
  net.setInput(input);
  const cv::Mat out = net.forward().clone();
  if (type) *type = net.getLayer(params.name)->type;
  if (class_name) *class_name = typeid(*net.getLayer(params.name)).name();
  return out;
}

// One layer with these weights and bias (then a SELU when `selu`).
cv::Mat run_layer(cv::dnn::LayerParams params, const cv::Mat& input, const cv::Mat& weights,
                  const cv::Mat& bias, bool selu, DnnLayers layers, std::string* type) {
  params.blobs = {weights};
  if (!bias.empty()) params.blobs.push_back(bias);
  params.set("bias_term", !bias.empty());
  return run_one_layer(params, input, layers, type, selu ? "Selu" : nullptr);
}

cv::Mat deconvolve(const cv::Mat& input, const cv::Mat& weights, const cv::Mat& bias, Geometry g,
                   bool selu, DnnLayers layers, std::string* type = nullptr) {
  cv::dnn::LayerParams params;
  params.type = "Deconvolution";
  params.set("num_output", weights.size[1]);
  const int kernel[] = {g.kernel, g.kernel}, stride[] = {g.stride, g.stride},
            pads[] = {g.pad, g.pad, g.pad, g.pad}, adjust[] = {g.adjust, g.adjust};
  params.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
  params.set("stride", cv::dnn::DictValue::arrayInt(stride, 2));
  params.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
  params.set("adj", cv::dnn::DictValue::arrayInt(adjust, 2));
  return run_layer(params, input, weights, bias, selu, layers, type);
}

struct Shape {
  int cin, cout, h, w;
  bool bias, selu;
};

// Each float rounded to the nearest bfloat16 (ties to even): what the bfloat16 stand-ins multiply.
cv::Mat rounded_to_bfloat16(const cv::Mat& m) {
  cv::Mat out = m.clone();
  float* v = out.ptr<float>();
  for (std::size_t i = 0; i < out.total(); ++i) {
    std::uint32_t bits;
    std::memcpy(&bits, v + i, sizeof bits);
    bits = (bits + 0x7fffu + ((bits >> 16) & 1u)) & 0xffff0000u;
    std::memcpy(v + i, &bits, sizeof bits);
  }
  return out;
}

// A random layer of shape `s`: input in [-2, 2], weights (of `weight_shape`) and bias in [-1, 1].
struct RandomLayer {
  cv::Mat input, weights, bias;
  RandomLayer(cv::RNG& rng, const Shape& s, const std::vector<int>& weight_shape)
      : input({2, s.cin, s.h, s.w}, CV_32F), weights(weight_shape, CV_32F) {
    rng.fill(input, cv::RNG::UNIFORM, -2, 2);
    rng.fill(weights, cv::RNG::UNIFORM, -1, 1);
    if (s.bias) {
      bias.create(1, s.cout, CV_32F);
      rng.fill(bias, cv::RNG::UNIFORM, -1, 1);
    }
  }
  // What a bfloat16 stand-in multiplies, when `type` is one.
  void round_if_bfloat16(const std::string& type) {
    if (type.size() < 4 || type.substr(type.size() - 4) != "Bf16") return;
    input = rounded_to_bfloat16(input);
    weights = rounded_to_bfloat16(weights);
  }
};

// The precisions a stand-in runs in here: float, and bfloat16 where the CPU has it.
std::vector<bool> precisions() {
  if (bfloat16_products_supported()) return {false, true};
  return {false};
}

DnnLayers stand_ins(bool bfloat16) {
  DnnLayers layers;
  layers.bfloat16_products = bfloat16;
  return layers;
}

// The layer type that runs a product stand-in with `outputs` channels.
std::string stand_in_type(const std::string& name, bool bfloat16, int outputs) {
  return name + (bfloat16 && outputs >= 8 ? "Bf16" : "");
}

TEST(SubpixelDeconvolution, MatchesOpenCvsTransposedConvolution) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  // Output channels in blocks of 6, of 4 with a partial block, of 2 and 1 (and in bfloat16 of
  // 6, 8, 4 and 12); widths below, at and above a vector; one-pixel planes; odd input channels.
  const std::vector<Shape> shapes = {
      {5, 6, 3, 7, true, false},
      {7, 4, 4, 9, false, true},
      {3, 2, 1, 1, true, false},
      {13, 5, 2, 16, true, true},
      {20, 12, 5, 3, false, false},
      {9, 1, 6, 17, true, false},
      {40, 18, 4, 8, true, true},
      {300, 7, 2, 5, false, false},
      {31, 16, 9, 21, true, true},
      {3, 8, 16, 40, true, false},
      {288, 96, 4, 8, false, false},
      {56, 36, 3, 70, true, true},
      // the 2x2 geometry works in bands of rows: 8 rows of 40 at 96 outputs, a partial one last
      {24, 96, 20, 40, true, true},
      {24, 1, 20, 40, true, true},  // PP-OCR's last layer: 2x2 with one output, its own path
      {24, 2, 3, 33, false, true},
      // PP-OCR's first 2x2 layer at 640x480: 7.4 MB of output, written past the caches
      {24, 24, 120, 160, true, true}};
  cv::RNG rng(11);
  // MiniNet's 3x3 (padding 1, output padding 1) and PP-OCR's DB head's 2x2 (no padding).
  for (const Geometry g : {Geometry{3, 2, 1, 1}, Geometry{2, 2, 0, 0}})
    for (const bool bfloat16 : precisions())
      for (const Shape& s : shapes) {
        RandomLayer l(rng, s, {s.cin, s.cout, g.kernel, g.kernel});
        std::string type;
        const cv::Mat got =
            deconvolve(l.input, l.weights, l.bias, g, s.selu, stand_ins(bfloat16), &type);
        // The 2x2 geometry (PP-OCR's DB head) stays in float.
        EXPECT_EQ(type, stand_in_type("KeyfleetSubpixelDeconvolution", bfloat16 && g.kernel == 3,
                                      s.cout));
        l.round_if_bfloat16(type);
        const cv::Mat expected =
            deconvolve(l.input, l.weights, l.bias, g, s.selu, DnnLayers::opencv());
        ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
        EXPECT_EQ(cv::dnn::shape(got), (cv::dnn::MatShape{2, s.cout, 2 * s.h, 2 * s.w}));
        // Sums of up to 4 x cin products of magnitude <= 2, in another order than OpenCV's
        // (products of bfloat16 values are exact in float).
        EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * 4 * s.cin * 2 + 1e-6)
            << "kernel " << g.kernel << ", " << s.cin << " -> " << s.cout << ", " << s.w << "x"
            << s.h << ", " << type;
      }
}

TEST(SubpixelDeconvolution, LeavesOtherGeometriesToOpenCv) {
  cv::RNG rng(12);
  for (const Geometry g :
       {Geometry{3, 1, 1, 0}, Geometry{3, 2, 1, 0}, Geometry{4, 2, 1, 0}, Geometry{3, 2, 0, 1},
        Geometry{2, 1, 0, 0}, Geometry{2, 2, 1, 0}, Geometry{2, 2, 0, 1}}) {
    cv::Mat input({1, 4, 5, 6}, CV_32F), weights({4, 3, g.kernel, g.kernel}, CV_32F);
    rng.fill(input, cv::RNG::UNIFORM, -2, 2);
    rng.fill(weights, cv::RNG::UNIFORM, -1, 1);
    std::string type;
    const cv::Mat got = deconvolve(input, weights, cv::Mat(), g, false, DnnLayers{}, &type);
    EXPECT_EQ(type, "Deconvolution") << "kernel " << g.kernel << " stride " << g.stride;
    EXPECT_EQ(cv::norm(got, deconvolve(input, weights, cv::Mat(), g, false, DnnLayers::opencv()),
                       cv::NORM_INF),
              0.0);
  }
}

cv::Mat convolve_1x1(const cv::Mat& input, const cv::Mat& weights, const cv::Mat& bias, bool selu,
                     DnnLayers layers, std::string* type = nullptr) {
  cv::dnn::LayerParams params;
  params.type = "Convolution";
  params.set("num_output", weights.size[0]);
  const int kernel[] = {1, 1};
  params.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
  return run_layer(params, input, weights, bias, selu, layers, type);
}

TEST(PointwiseStandIn, MatchesOpenCvsConvolution) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  // Output channels in whole blocks of 6 and 4 and in partial ones (bfloat16: also 8 and 12);
  // pixel counts that fill whole column blocks (16, 24, 48; 32, 64, 96) and that do not (in
  // float, whole row blocks: a remainder block of its own, alone, after several stripes, with the
  // input channels summed in several chunks); odd input channels; an output of 7.4 MB without
  // an activation (PP-OCR's 12 -> 96 at 640x480: written past the caches) and one of 10 MB with
  // one (16 -> 32, activated in a small buffer and streamed, a remainder block after).
  const std::vector<Shape> shapes = {
      {12, 96, 120, 160, true, false}, {3, 12, 8, 16, true, true},    {12, 24, 4, 12, false, false},
      {5, 4, 3, 8, true, false},       {7, 2, 6, 8, false, true},     {9, 5, 3, 7, true, true},
      {386, 386, 4, 8, true, false},   {300, 7, 1, 1, false, true},   {28, 1, 5, 11, true, false},
      {31, 16, 9, 21, true, true},     {96, 48, 8, 12, false, true},  {192, 8, 2, 24, true, false},
      {25, 9, 1, 1, true, true},       {200, 12, 13, 11, true, true}, {600, 6, 7, 9, false, true},
      {16, 32, 10, 9, true, false},    {16, 32, 250, 320, true, true}};
  cv::RNG rng(14);
  for (const bool bfloat16 : precisions())
    for (const Shape& s : shapes) {
      RandomLayer l(rng, s, {s.cout, s.cin, 1, 1});
      std::string type;
      const cv::Mat got =
          convolve_1x1(l.input, l.weights, l.bias, s.selu, stand_ins(bfloat16), &type);
      EXPECT_EQ(type, stand_in_type("KeyfleetPointwise", bfloat16, s.cout));
      l.round_if_bfloat16(type);
      const cv::Mat expected =
          convolve_1x1(l.input, l.weights, l.bias, s.selu, DnnLayers::opencv());
      ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
      EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * s.cin * 2 + 1e-6)
          << s.cin << " -> " << s.cout << ", " << s.w << "x" << s.h << ", " << type;
    }
}

// What the int8 stand-in computes (pointwise_int8.hpp), in double from the same quantized values:
// weights per output channel to +-127, each image's input over its own range (zero included) to
// 0..127. `bound`: how far that may be from the float product at each output, at most (half a
// step of each operand on every product, and their product).
cv::Mat quantized_1x1(const cv::Mat& input, const cv::Mat& weights, const cv::Mat& bias,
                      cv::Mat* bound) {
  const int images = input.size[0], cin = input.size[1], pixels = input.size[2] * input.size[3];
  const int cout = weights.size[0];
  cv::Mat out({images, cout, input.size[2], input.size[3]}, CV_32F);
  bound->create(out.dims, out.size.p, CV_32F);
  std::vector<double> scale(cout);
  std::vector<long> q(std::size_t(cout) * cin);
  for (int o = 0; o < cout; ++o) {
    const float* w = weights.ptr<float>() + std::size_t(o) * cin;
    float largest = 0;
    for (int i = 0; i < cin; ++i) largest = std::max(largest, std::abs(w[i]));
    const float s = largest > 0 ? largest / 127 : 1.f;
    scale[o] = s;
    for (int i = 0; i < cin; ++i) q[std::size_t(o) * cin + i] = std::lrint(w[i] / s);
  }
  for (int n = 0; n < images; ++n) {
    const float* x = input.ptr<float>(n);
    const auto [lo, hi] = std::minmax_element(x, x + std::size_t(cin) * pixels);
    const float lowest = std::min(*lo, 0.f), highest = std::max(*hi, 0.f);
    const float step = highest > lowest ? (highest - lowest) / 127 : 1.f, inverse = 1.f / step;
    const long zero = std::clamp(std::lrint(-lowest / step), 0L, 127L);
    for (int o = 0; o < cout; ++o)
      for (int p = 0; p < pixels; ++p) {
        double sum = 0, most = 0;
        for (int i = 0; i < cin; ++i) {
          const float xi = x[std::size_t(i) * pixels + p];
          const long xq = std::clamp(std::lrint(xi * inverse) + zero, 0L, 127L);
          sum += double(q[std::size_t(o) * cin + i]) * double(xq - zero);
          const double w = weights.ptr<float>()[std::size_t(o) * cin + i];
          most += std::abs(w) * step / 2 + std::abs(xi) * scale[o] / 2 + step * scale[o] / 4;
        }
        const std::size_t at = std::size_t(o) * pixels + p;
        out.ptr<float>(n)[at] =
            float(scale[o] * step * sum + (bias.empty() ? 0.0 : bias.ptr<float>()[o]));
        bound->ptr<float>(n)[at] = float(most);
      }
  }
  return out;
}

TEST(PointwiseStandIn, InInt8IsTheQuantizedProductAndCloseToOpenCvs) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  // KEYFLEET_INT8_INSTRUCTIONS (ctest sets each): the products must run with that set.
  const char* asked = std::getenv("KEYFLEET_INT8_INSTRUCTIONS");
  const std::string kernels = segmenter_kernels(false, true);
  if (asked) {
    std::string wanted = asked;
    std::transform(wanted.begin(), wanted.end(), wanted.begin(), ::toupper);
    if (kernels.find("int8 (" + wanted + ")") == std::string::npos)
      GTEST_SKIP() << "this CPU cannot run the int8 products with " << wanted << ": " << kernels;
  }
  // 64 or more channels each way: output channels in whole and partial blocks of 4 and 2, input
  // channels in whole and partial quads, columns in whole and partial blocks of 16 and 32 (a
  // remainder block alone, and after several stripes).
  const std::vector<Shape> shapes = {{64, 64, 4, 8, true, false},   {67, 66, 3, 7, false, false},
                                     {96, 130, 5, 13, true, false}, {385, 70, 2, 16, true, false},
                                     {128, 64, 1, 1, false, false}, {64, 97, 6, 11, true, false},
                                     {72, 96, 13, 11, true, false}};
  DnnLayers int8 = DnnLayers::in_float();
  int8.int8_pointwise = true;
  cv::RNG rng(33);
  for (const Shape& s : shapes) {
    RandomLayer l(rng, s, {s.cout, s.cin, 1, 1});
    l.input.ptr<float>(1)[0] = 7.f;  // the second image over another range than the first
    std::string type;
    const cv::Mat got = convolve_1x1(l.input, l.weights, l.bias, false, int8, &type);
    EXPECT_EQ(type, "KeyfleetPointwiseInt8");
    cv::Mat bound;
    const cv::Mat quantized = quantized_1x1(l.input, l.weights, l.bias, &bound);
    const cv::Mat exact = convolve_1x1(l.input, l.weights, l.bias, false, DnnLayers::opencv());
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(exact));
    double lowest, highest;
    cv::minMaxIdx(exact, &lowest, &highest);
    const double spread = highest - lowest;
    // The integer sums are exact: only the float scaling differs from the double reference.
    EXPECT_LT(cv::norm(got, quantized, cv::NORM_INF), 1e-5 * spread)
        << s.cin << " -> " << s.cout << ", " << s.w << "x" << s.h;
    // Against float: within the quantization's bound everywhere, 0.5 % of the outputs' spread
    // on average.
    cv::Mat error = cv::abs(got - exact) - (bound + 1e-5 * spread);
    EXPECT_LE(cv::countNonZero(error.reshape(1, 1) > 0), 0) << s.cin << " -> " << s.cout;
    EXPECT_LT(cv::norm(got, exact, cv::NORM_L1) / double(exact.total()), 0.005 * spread)
        << s.cin << " -> " << s.cout;
  }
  // Fewer than 64 channels either way: the float product (quantizing the input would cost more
  // than the integer products save).
  for (const Shape& s : {Shape{63, 96, 2, 8, true, false}, Shape{96, 32, 2, 8, true, false}}) {
    RandomLayer l(rng, s, {s.cout, s.cin, 1, 1});
    std::string type;
    const cv::Mat got = convolve_1x1(l.input, l.weights, l.bias, false, int8, &type);
    EXPECT_EQ(type, "KeyfleetPointwise") << s.cin << " -> " << s.cout;
    const cv::Mat expected = convolve_1x1(l.input, l.weights, l.bias, false, DnnLayers::opencv());
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * s.cin * 2 + 1e-6);
  }
}

cv::Mat convolve_3x3(const cv::Mat& input, const cv::Mat& weights, const cv::Mat& bias, bool selu,
                     DnnLayers layers, int stride, std::string* type = nullptr) {
  cv::dnn::LayerParams params;
  params.type = "Convolution";
  params.set("num_output", weights.size[0]);
  const int kernel[] = {3, 3}, strides[] = {stride, stride}, pads[] = {1, 1, 1, 1};
  params.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
  params.set("stride", cv::dnn::DictValue::arrayInt(strides, 2));
  params.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
  return run_layer(params, input, weights, bias, selu, layers, type);
}

TEST(Convolution3x3StandIn, MatchesOpenCvsConvolution) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  // Output channels in whole and partial blocks of every shape; planes of one pixel, one row,
  // one column and wider than a block; odd input channels. In float, 8 or more inputs and
  // outputs run as Winograd's F(4x4, 3x3): sides not a multiple of 4 (a last block partly
  // outside), rows of blocks past a vector of 8 (33 columns: one column into a ninth block), and
  // PP-OCR's 96 -> 24 in several bands of block rows.
  const std::vector<Shape> shapes = {
      {3, 12, 8, 16, true, true},   {16, 24, 5, 7, false, false},  {5, 4, 1, 1, true, false},
      {7, 2, 1, 30, false, true},   {9, 5, 30, 1, true, true},     {64, 96, 12, 20, true, false},
      {33, 8, 6, 9, false, true},   {96, 256, 3, 4, true, false},  {20, 36, 15, 40, true, true},
      {96, 24, 31, 41, true, true}, {8, 8, 1, 1, true, false},     {12, 10, 2, 35, false, true},
      {16, 16, 9, 33, true, false}, {96, 24, 120, 160, true, true}};
  cv::RNG rng(16);
  for (const bool bfloat16 : precisions())
    for (const Shape& s : shapes) {
      RandomLayer l(rng, s, {s.cout, s.cin, 3, 3});
      std::string type;
      const cv::Mat got =
          convolve_3x3(l.input, l.weights, l.bias, s.selu, stand_ins(bfloat16), 1, &type);
      EXPECT_EQ(type, stand_in_type("KeyfleetConvolution3x3", bfloat16, s.cout));
      l.round_if_bfloat16(type);
      const cv::Mat expected =
          convolve_3x3(l.input, l.weights, l.bias, s.selu, DnnLayers::opencv(), 1);
      ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
      // Sums of up to 9 x cin products of magnitude <= 2, in another order than OpenCV's.
      EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * 9 * s.cin * 2 + 1e-6)
          << s.cin << " -> " << s.cout << ", " << s.w << "x" << s.h << ", " << type;
    }
  // Stride 2 stays OpenCV's beyond 4 inputs (below: the strided stand-in).
  RandomLayer l(rng, {5, 6, 8, 8, false, false}, {6, 5, 3, 3});
  std::string type;
  convolve_3x3(l.input, l.weights, l.bias, false, stand_ins(false), 2, &type);
  EXPECT_EQ(type, "Convolution");
}

// The stride-2 stand-in for a network's first layer (k x k, padding k / 2, up to 4 inputs) against
// OpenCV's convolution: PP-OCR's 3 -> 16 3x3 (at a size whose output rows take several bands, and
// a batch of two), a 5x5, one input, odd and even sides, a plane of one pixel, outputs in whole and
// partial row blocks, with and without bias and a SELU after it.
TEST(StridedConvolutionStandIn, MatchesOpenCvsConvolution) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  struct Case {
    Shape shape;
    int kernel;
  };
  const std::vector<Case> cases = {
      {{3, 16, 256, 320, true, true}, 3}, {{3, 16, 7, 9, false, false}, 3},
      {{1, 5, 8, 6, true, false}, 3},     {{4, 24, 1, 1, true, true}, 3},
      {{3, 8, 11, 13, false, true}, 5},   {{2, 30, 2, 3, true, false}, 5}};
  cv::RNG rng(29);
  for (const Case& c : cases) {
    const Shape& s = c.shape;
    RandomLayer l(rng, s, {s.cout, s.cin, c.kernel, c.kernel});
    const auto run = [&](DnnLayers layers, std::string* type) {
      cv::dnn::LayerParams params;
      params.type = "Convolution";
      params.set("num_output", s.cout);
      const int kernel[] = {c.kernel, c.kernel}, strides[] = {2, 2},
                pads[] = {c.kernel / 2, c.kernel / 2, c.kernel / 2, c.kernel / 2};
      params.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
      params.set("stride", cv::dnn::DictValue::arrayInt(strides, 2));
      params.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
      return run_layer(params, l.input, l.weights, l.bias, s.selu, layers, type);
    };
    std::string type;
    const cv::Mat got = run(stand_ins(false), &type);
    const cv::Mat expected = run(DnnLayers::opencv(), nullptr);
    EXPECT_EQ(type, "KeyfleetStridedConvolution");
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
    // Sums of up to k x k x cin products of magnitude <= 2, in another order than OpenCV's.
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * 25 * s.cin * 2 + 1e-6)
        << s.cin << " -> " << s.cout << ", " << c.kernel << "x" << c.kernel << ", " << s.w << "x"
        << s.h;
  }
}

// The depthwise stand-in against OpenCV's convolution: PP-OCR's 3x3 and 5x5 kernels (stride 2 down
// columns too, as its recogniser), MiniNet's dilated ones, no padding, planes narrower than the
// kernel's reach and widths either side of the SIMD paths (8 and 32 columns), a zero tap, with and
// without bias.
TEST(DepthwiseStandIn, MatchesOpenCvsConvolution) {
  struct Case {
    int kernel, dilation, pad, h, w;
    bool bias;
    int stride_down = 1;    // PP-OCR's recogniser: 5x5 with stride (2, 1)
    int stride_across = 1;  // its detector: 3x3 and 5x5 with stride 2 both ways
  };
  const std::vector<Case> cases = {
      {3, 1, 1, 9, 40, true},        {5, 1, 2, 7, 33, true},        {3, 2, 2, 6, 70, false},
      {3, 4, 4, 5, 31, true},        {5, 1, 0, 8, 12, true},        {3, 1, 1, 1, 1, true},
      {5, 1, 2, 2, 3, false},        {3, 1, 1, 4, 8, true},         {7, 1, 3, 16, 65, true},
      {5, 1, 2, 6, 40, true, 2},     {5, 1, 2, 7, 41, false, 2},    {3, 1, 1, 1, 9, true, 2},
      {3, 1, 0, 9, 17, true, 3},     {3, 1, 1, 9, 40, true, 2, 2},  {5, 1, 2, 7, 41, false, 2, 2},
      {3, 1, 1, 1, 1, true, 2, 2},   {3, 1, 1, 8, 33, true, 1, 2},  {5, 1, 2, 12, 130, true, 2, 2},
      {3, 2, 2, 6, 70, false, 1, 2}, {3, 1, 0, 5, 16, true, 2, 2},  {5, 1, 1, 9, 37, true, 2, 2},
      {7, 1, 3, 10, 50, true, 2, 2}, {5, 2, 3, 11, 45, false, 1, 2}};
  cv::RNG rng(17);
  for (const Case& c : cases) {
    const int channels = 6;
    RandomLayer l(rng, {channels, channels, c.h, c.w, c.bias, false},
                  {channels, 1, c.kernel, c.kernel});
    l.weights.ptr<float>()[1] = 0.f;  // a skipped tap
    const auto run = [&](DnnLayers layers, std::string* type) {
      cv::dnn::LayerParams params;
      params.type = "Convolution";
      params.set("num_output", channels);
      params.set("group", channels);
      const int kernel[] = {c.kernel, c.kernel}, dilation[] = {c.dilation, c.dilation},
                pads[] = {c.pad, c.pad, c.pad, c.pad}, stride[] = {c.stride_down, c.stride_across};
      params.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
      params.set("stride", cv::dnn::DictValue::arrayInt(stride, 2));
      params.set("dilation", cv::dnn::DictValue::arrayInt(dilation, 2));
      params.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
      return run_layer(params, l.input, l.weights, l.bias, false, layers, type);
    };
    std::string type;
    const cv::Mat got = run(DnnLayers::in_float(), &type);
    const cv::Mat expected = run(DnnLayers::opencv(), nullptr);
    // Stride 2 along rows only with AVX2 and FMA (the portable code takes 1), and not for 3x3
    // (OpenCV's own kernel is faster there).
    const bool taken = c.stride_across == 1 || (matrix_product_layers_supported() && c.kernel != 3);
    EXPECT_EQ(type, taken ? "KeyfleetDepthwise" : "Convolution");
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
    // Sums of up to 49 products of magnitude <= 2, in another order than OpenCV's.
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * 49 * 2 + 1e-6)
        << "kernel " << c.kernel << ", dilation " << c.dilation << ", pad " << c.pad << ", " << c.w
        << "x" << c.h << ", stride " << c.stride_down << " x " << c.stride_across;
  }
}

// A convolution followed by PP-OCR's chain of activations (hard swish, then its learnable affine
// block's scale and shift, which OpenCV's importer makes two Power layers; OpenCV offers each to
// the convolution in turn): the stand-in takes the whole chain and applies it in order, for the
// 1x1 product and the depthwise stand-in alike (the two Power layers as one multiply-add, after a
// hard swish in the same pass; after a ReLU, OpenCV's own activation, as a pass of their own).
// (Before, a stand-in took the first and left the rest layers of their own; before that, the
// second replaced the first.)
TEST(StandIns, AChainOfActivationsAfterThemIsAppliedWholeInOrder) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  cv::RNG rng(15);
  struct Case {
    const char* stand_in;
    int cout, group, kernel;
  };
  for (const char* first : {"HardSwish", "ReLU"})  // the scale and shift join a hard swish only
    for (const Case& c : {Case{"KeyfleetPointwise", 12, 1, 1}, Case{"KeyfleetDepthwise", 16, 16, 3},
                          Case{"KeyfleetDepthwise", 16, 16, 5}}) {
      const Shape s{16, c.cout, 7, 9, true, false};
      RandomLayer l(rng, s, {s.cout, s.cin / c.group, c.kernel, c.kernel});
      // fused: the number of the activations that did not run as layers of their own.
      const auto run = [&](DnnLayers layers, std::string* type, int* fused = nullptr) {
        cv::dnn::LayerParams conv;
        conv.name = "conv";
        conv.type = "Convolution";
        conv.set("num_output", s.cout);
        conv.set("group", c.group);
        const int kernel[] = {c.kernel, c.kernel}, pad = c.kernel / 2,
                  pads[] = {pad, pad, pad, pad};
        conv.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
        conv.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
        conv.set("bias_term", true);
        conv.blobs = {l.weights, l.bias};
        std::optional<DnnLayersScope> scope;
        if (layers.any()) scope.emplace(layers);
        cv::dnn::Net net;
        net.addLayerToPrev(conv.name, conv.type, conv);
        cv::dnn::LayerParams activation;
        activation.name = activation.type = first;
        net.addLayerToPrev(activation.name, activation.type, activation);
        for (const auto& [name, scale, shift] :
             {std::tuple{"times_two", 2.f, 0.f}, std::tuple{"plus_one", 1.f, 1.f}}) {
          cv::dnn::LayerParams power;
          power.name = name;
          power.type = "Power";
          power.set("scale", scale);
          power.set("shift", shift);
          net.addLayerToPrev(power.name, power.type, power);
        }
        net.setInput(l.input);
        const cv::Mat out = net.forward().clone();
        if (type) *type = net.getLayer("conv")->type;
        if (fused) {
          std::vector<double> ticks;  // a layer fused into another is skipped: no time of its own
          net.getPerfProfile(ticks);
          const std::vector<cv::String> names = net.getLayerNames();
          *fused = 0;
          for (std::size_t i = 0; i < names.size() && i < ticks.size(); ++i)
            if (names[i] != "conv" && ticks[i] == 0) ++*fused;
        }
        return out;
      };
      const cv::Mat expected = run(DnnLayers::opencv(), nullptr);
      for (const bool bfloat16 : precisions()) {
        std::string type;
        int fused = 0;
        const cv::Mat got = run(stand_ins(bfloat16), &type, &fused);
        const bool depthwise = c.group > 1;  // never bfloat16
        EXPECT_EQ(type, depthwise ? c.stand_in : stand_in_type(c.stand_in, bfloat16, s.cout));
        EXPECT_EQ(fused, 3) << type << ": the " << first
                            << " and both Power layers run in the stand-in";
        // Sums of up to 25 products, through a hard swish or a ReLU, then doubled.
        const double tolerance = bfloat16 && !depthwise ? 0.1 : 2e-4;
        EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), tolerance) << type;
      }
    }
}

// Batched frames reach the transposed convolutions as slices of concatenated blobs (images not
// contiguous): a batch gives each frame's own mask.
TEST(SubpixelDeconvolution, ShippedMiniNetMasksOfABatchAreThoseOfEachFrame) {
  DnnTextSegmenter net(locate_model("mininet_text.onnx", "segmenter model"), 1, cv::Size(128, 64));
  cv::Mat a(64, 128, CV_8UC3), b(64, 128, CV_8UC3);
  cv::RNG rng(13);
  rng.fill(a, cv::RNG::UNIFORM, 0, 256);
  rng.fill(b, cv::RNG::UNIFORM, 0, 256);
  const std::vector<cv::Mat> both = net.segment({a, b});
  ASSERT_EQ(both.size(), 2u);
  EXPECT_EQ(cv::countNonZero(both[0] != net.segment({a}).at(0)), 0);
  EXPECT_EQ(cv::countNonZero(both[1] != net.segment({b}).at(0)), 0);
}

// The hard swish stand-in on both sides of its kinks (-3 and 3) and beyond, over a length that
// is no multiple of the SIMD width: the definition to float rounding, in place as well.
TEST(HardSwishStandIn, ComputesTheDefinition) {
  std::vector<float> x;
  for (float v = -9.f; v <= 9.f; v += 0.0137f) x.push_back(v);
  x.insert(x.end(), {-3.f, 3.f, 0.f, -1e30f, 1e30f});
  std::vector<float> y(x.size());
  hard_swish_vectorised(x.data(), y.data(), int(x.size()));
  for (std::size_t i = 0; i < x.size(); ++i) {
    const float expected = x[i] * std::min(std::max(x[i] + 3.f, 0.f), 6.f) / 6.f;
    EXPECT_NEAR(y[i], expected, 1e-6f * std::max(1.f, std::abs(expected))) << "x = " << x[i];
  }
  hard_swish_vectorised(x.data(), x.data(), int(x.size()));
  EXPECT_EQ(x, y);
}

// The one layer `params` through keyfleet's stand-in (all in float) and through OpenCV's own:
// {the stand-in's output, OpenCV's}; fails the test where no stand-in ran.
std::pair<cv::Mat, cv::Mat> stand_in_beside_opencv(const cv::dnn::LayerParams& params,
                                                   const cv::Mat& input) {
  std::string opencv_class, stand_in_class;
  cv::Mat expected =
      run_one_layer(params, input, DnnLayers::opencv(), nullptr, nullptr, &opencv_class);
  cv::Mat got =
      run_one_layer(params, input, DnnLayers::in_float(), nullptr, nullptr, &stand_in_class);
  EXPECT_NE(stand_in_class, opencv_class) << "the stand-in did not run";
  return {got, expected};
}

// The Sigmoid stand-in against OpenCV's own layer: values across the logistic curve and far out
// on both sides (saturating to 0 and 1, no NaN), a length that is no multiple of the chunk or the
// SIMD width.
TEST(SigmoidStandIn, MatchesOpenCvsSigmoid) {
  cv::Mat input({1, 3, 17, 23}, CV_32F);
  cv::RNG rng(31);
  rng.fill(input, cv::RNG::UNIFORM, -12.0, 12.0);
  float* v = input.ptr<float>();
  v[0] = -1e30f, v[1] = 1e30f, v[2] = 0.f, v[3] = -88.f, v[4] = 90.f;
  cv::dnn::LayerParams params;
  params.type = "Sigmoid";
  const auto [got, expected] = stand_in_beside_opencv(params, input);
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6);
  EXPECT_EQ(got.ptr<float>()[0], 0.f);
  EXPECT_EQ(got.ptr<float>()[1], 1.f);
  EXPECT_FLOAT_EQ(got.ptr<float>()[2], 0.5f);
}

// The Power stand-in, (shift + scale x)^power, against OpenCV's own layer: the SIMD path (power 1)
// on lengths that are no multiple of the SIMD width, and std::pow for another power.
TEST(PowerStandIn, ComputesWhatOpenCvsPowerLayerDoes) {
  cv::RNG rng(16);
  cv::Mat input({1, 3, 5, 7}, CV_32F);
  rng.fill(input, cv::RNG::UNIFORM, 0.1, 3);
  for (const auto& [power, scale, shift] :
       {std::tuple{1.f, 0.37f, -1.25f}, std::tuple{1.f, -2.f, 0.f}, std::tuple{2.f, 0.5f, 1.f},
        std::tuple{0.5f, 1.f, 0.25f}}) {
    cv::dnn::LayerParams params;
    params.type = "Power";
    params.set("power", power);
    params.set("scale", scale);
    params.set("shift", shift);
    const auto [got, expected] = stand_in_beside_opencv(params, input);
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-5)
        << "power " << power << ", scale " << scale << ", shift " << shift;
  }
  // After a convolution that stays OpenCV's (stride 2, 5 inputs), which folds a Power layer's
  // scale and shift into its weights: the stand-in, a PowerLayer too, is folded the same way.
  RandomLayer l(rng, {5, 6, 8, 8, true, false}, {6, 5, 3, 3});
  const auto folded = [&](DnnLayers layers, std::string* type) {
    cv::dnn::LayerParams conv;
    conv.name = "conv";
    conv.type = "Convolution";
    conv.set("num_output", 6);
    const int kernel[] = {3, 3}, strides[] = {2, 2}, pads[] = {1, 1, 1, 1};
    conv.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
    conv.set("stride", cv::dnn::DictValue::arrayInt(strides, 2));
    conv.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
    conv.set("bias_term", true);
    conv.blobs = {l.weights.clone(), l.bias.clone()};
    cv::dnn::LayerParams power;
    power.name = "power";
    power.type = "Power";
    power.set("scale", 0.5f);
    power.set("shift", -1.f);
    std::optional<DnnLayersScope> scope;
    if (layers.any()) scope.emplace(layers);
    cv::dnn::Net net;
    net.addLayerToPrev(conv.name, conv.type, conv);
    net.addLayerToPrev(power.name, power.type, power);
    net.setInput(l.input);
    const cv::Mat out = net.forward().clone();
    if (type) *type = net.getLayer("conv")->type;
    return out;
  };
  std::string conv_type;
  const cv::Mat got = folded(DnnLayers::in_float(), &conv_type);
  EXPECT_EQ(conv_type, "Convolution");
  EXPECT_LT(cv::norm(got, folded(DnnLayers::opencv(), nullptr), cv::NORM_INF), 1e-5);
}

// The inner product stand-in against OpenCV's InnerProduct with constant weights: PP-OCR's
// recogniser's last layer (40 steps x 120 -> 6625 characters, flagged transB as its importer does),
// one row, rows and outputs off every block size, with and without bias, the axis at 1 and 2.
TEST(InnerProductStandIn, MatchesOpenCvsInnerProduct) {
  if (!matrix_product_layers_supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layer stays";
  struct Case {
    std::vector<int> input;
    int axis, outputs;
    bool bias, trans_b;
  };
  const std::vector<Case> cases = {
      {{1, 40, 120}, 2, 6625, true, true}, {{1, 7}, 1, 5, false, false},
      {{3, 5, 4}, 1, 17, true, false},     {{2, 9, 33}, 2, 49, true, true},
      {{1, 1, 1}, 2, 1, true, false},      {{5, 64}, 1, 300, false, true}};
  cv::RNG rng(18);
  for (const Case& c : cases) {
    cv::Mat input(c.input, CV_32F);
    rng.fill(input, cv::RNG::UNIFORM, -2, 2);
    const int depth = int(input.total()) / cv::dnn::total(c.input, 0, c.axis);
    cv::Mat weights(c.outputs, depth, CV_32F), bias(1, c.outputs, CV_32F);
    rng.fill(weights, cv::RNG::UNIFORM, -1, 1);
    rng.fill(bias, cv::RNG::UNIFORM, -1, 1);
    cv::dnn::LayerParams params;
    params.type = "InnerProduct";
    params.set("num_output", c.outputs);
    params.set("axis", c.axis);
    params.set("bias_term", c.bias);
    params.set("transB", c.trans_b);
    params.blobs = {weights};
    if (c.bias) params.blobs.push_back(bias);
    std::string type;
    const cv::Mat got = run_one_layer(params, input, DnnLayers::in_float(), &type);
    const cv::Mat expected = run_one_layer(params, input, DnnLayers::opencv(), nullptr);
    EXPECT_EQ(type, "KeyfleetInnerProduct");
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
    // Sums of `depth` products of magnitude <= 2, in another order than OpenCV's.
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * depth * 2 + 1e-6)
        << c.outputs << " outputs of " << depth;
  }
}

// The softmax stand-in against OpenCV's: over the last axis (PP-OCR's recogniser: 6625 characters
// a step), over a middle one (positions after it side by side), log-softmax, large logits.
TEST(SoftmaxStandIn, MatchesOpenCvsSoftmax) {
  struct Case {
    std::vector<int> input;
    int axis;
    bool log;
    double scale;
  };
  const std::vector<Case> cases = {{{1, 40, 6625}, 2, false, 10}, {{1, 40, 6625}, -1, false, 10},
                                   {{2, 3, 5, 7}, 1, false, 3},   {{2, 3, 5, 7}, 2, true, 3},
                                   {{4, 13}, 1, true, 50},        {{1, 8, 9, 9}, 3, false, 1},
                                   {{3, 1}, 1, false, 1}};
  cv::RNG rng(19);
  for (const Case& c : cases) {
    cv::Mat input(c.input, CV_32F);
    rng.fill(input, cv::RNG::UNIFORM, -c.scale, c.scale);
    cv::dnn::LayerParams params;
    params.type = "Softmax";
    params.set("axis", c.axis);
    params.set("log_softmax", c.log);
    std::string type;
    const cv::Mat got = run_one_layer(params, input, DnnLayers::in_float(), &type);
    const cv::Mat expected = run_one_layer(params, input, DnnLayers::opencv(), nullptr);
    EXPECT_EQ(type, "KeyfleetSoftmax");
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), c.log ? 1e-4 : 1e-6)
        << "axis " << c.axis << (c.log ? ", log" : "");
  }
}

// Global average pooling (the squeeze of PP-OCR's squeeze-and-excitation blocks) against OpenCV's:
// planes of one pixel, fewer pixels than a vector, not a whole number of the four vectors summed
// at a time, and the detector's 96 x 64 x 80; a batch of two; one-dimensional planes. Other
// poolings stay OpenCV's.
TEST(GlobalAveragePoolStandIn, MatchesOpenCvsPooling) {
  const std::vector<std::vector<int>> shapes = {{1, 3, 1, 1},  {1, 5, 2, 3},    {2, 7, 9, 13},
                                                {1, 4, 16, 8}, {1, 96, 64, 80}, {2, 6, 37}};
  cv::RNG rng(23);
  for (const auto& shape : shapes) {
    cv::Mat input(shape, CV_32F);
    rng.fill(input, cv::RNG::UNIFORM, -4.0, 6.0);
    cv::dnn::LayerParams params;
    params.type = "Pooling";
    params.set("pool", "AVE");
    params.set("global_pooling", true);
    std::string type;
    const cv::Mat got = run_one_layer(params, input, DnnLayers::in_float(), &type);
    const cv::Mat expected = run_one_layer(params, input, DnnLayers::opencv(), nullptr);
    EXPECT_EQ(type, "KeyfleetGlobalAveragePool");
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
    // Means of values within [-4, 6], summed in another order than OpenCV's.
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-5)
        << cv::dnn::toString(cv::dnn::shape(input));
  }
  cv::Mat input({1, 2, 6, 6}, CV_32F);
  rng.fill(input, cv::RNG::UNIFORM, -1.0, 1.0);
  for (const char* pool : {"MAX", "AVE"}) {
    cv::dnn::LayerParams params;
    params.type = "Pooling";
    params.set("pool", pool);
    const bool global = std::string(pool) == "MAX";  // global max; average over 2x2 windows
    params.set("global_pooling", global);
    const int kernel[] = {2, 2}, stride[] = {2, 2};
    if (!global) {
      params.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
      params.set("stride", cv::dnn::DictValue::arrayInt(stride, 2));
    }
    std::string type;
    run_one_layer(params, input, DnnLayers::in_float(), &type);
    EXPECT_EQ(type, "Pooling") << pool;
  }
}

// Nearest-neighbour Resize (PP-OCR's FPN upsamplings) against OpenCV's, to the bit: factors 2,
// 4 and 8, unequal factors, rows narrower and wider than a vector, a batch of two, an output
// that is a slice of a concatenation; a factor of 3 (OpenCV's own loop, inside the stand-in) and
// a bilinear resize (OpenCV's layer) too.
TEST(NearestUpsamplingStandIn, MatchesOpenCvsResize) {
  struct Case {
    std::vector<int> shape;
    int zoom_y, zoom_x;
    const char* then;
  };
  const std::vector<Case> cases = {
      {{1, 96, 8, 10}, 2, 2, nullptr},  {{1, 24, 8, 10}, 8, 8, nullptr},
      {{1, 24, 16, 20}, 4, 4, nullptr}, {{2, 3, 5, 3}, 2, 4, nullptr},
      {{1, 2, 3, 7}, 8, 2, nullptr},    {{1, 4, 6, 5}, 3, 3, nullptr},
      {{2, 5, 4, 6}, 2, 2, "Concat"}};
  cv::RNG rng(29);
  for (const Case& c : cases) {
    cv::Mat input(c.shape, CV_32F);
    rng.fill(input, cv::RNG::UNIFORM, -3.0, 3.0);
    cv::dnn::LayerParams params;
    params.type = "Resize";
    params.set("interpolation", "nearest");
    params.set("zoom_factor_y", c.zoom_y);
    params.set("zoom_factor_x", c.zoom_x);
    std::string type;
    const cv::Mat got = run_one_layer(params, input, DnnLayers::in_float(), &type, c.then);
    const cv::Mat expected = run_one_layer(params, input, DnnLayers::opencv(), nullptr, c.then);
    const std::string label = cv::dnn::toString(cv::dnn::shape(input)) + " x" +
                              std::to_string(c.zoom_y) + "," + std::to_string(c.zoom_x);
    EXPECT_EQ(type, "KeyfleetNearestUpsampling") << label;
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected)) << label;
    EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0) << label;
  }
  cv::Mat input({1, 2, 4, 4}, CV_32F);
  rng.fill(input, cv::RNG::UNIFORM, -1.0, 1.0);
  cv::dnn::LayerParams params;
  params.type = "Resize";
  params.set("interpolation", "bilinear");
  params.set("zoom_factor", 2);
  std::string type;
  run_one_layer(params, input, DnnLayers::in_float(), &type);
  EXPECT_EQ(type, "Resize");
}

// A net of one Eltwise layer over inputs "a", "b" (and "c" where given), then `then` (an
// activation OpenCV fuses into it, or a Concat whose slice it writes) where given.
cv::Mat run_sum(cv::dnn::LayerParams params, const std::vector<cv::Mat>& inputs, DnnLayers layers,
                std::string* type, const char* then = nullptr) {
  std::optional<DnnLayersScope> scope;
  if (layers.any()) scope.emplace(layers);
  cv::dnn::Net net;
  std::vector<cv::String> names = {"a", "b", "c"};
  names.resize(inputs.size());
  net.setInputsNames(names);
  params.name = "sum";
  const int id = net.addLayer(params.name, "Eltwise", params);
  for (std::size_t i = 0; i < inputs.size(); ++i) net.connect(0, int(i), id, int(i));
  if (then) {
    cv::dnn::LayerParams next;
    next.type = next.name = then;
    net.addLayerToPrev(next.name, next.type, next);
  }
  for (std::size_t i = 0; i < inputs.size(); ++i) net.setInput(inputs[i], names[i]);
  const cv::Mat out = net.forward().clone();
  if (type) *type = net.getLayer(params.name)->type;
  return out;
}

// The FPN's additions against OpenCV's Eltwise, to the bit: the detector's 96 x 120 x 160, planes
// narrower than a vector, three inputs, a batch of two, a ReLU fused into the sum, a sum written
// into a slice of a concatenation; products and weighted sums stay OpenCV's.
TEST(ElementwiseSumStandIn, MatchesOpenCvsEltwise) {
  struct Case {
    std::vector<int> shape;
    int inputs;
    const char* then;
  };
  const std::vector<Case> cases = {{{1, 96, 120, 160}, 2, nullptr},
                                   {{1, 3, 1, 5}, 2, nullptr},
                                   {{2, 7, 9, 13}, 3, nullptr},
                                   {{1, 24, 30, 40}, 2, "ReLU"},
                                   {{2, 5, 4, 6}, 2, "Concat"}};
  cv::RNG rng(31);
  for (const Case& c : cases) {
    std::vector<cv::Mat> inputs;
    for (int i = 0; i < c.inputs; ++i) {
      inputs.emplace_back(c.shape, CV_32F);
      rng.fill(inputs.back(), cv::RNG::UNIFORM, -5.0, 5.0);
    }
    cv::dnn::LayerParams params;
    params.set("operation", "sum");
    std::string type;
    const cv::Mat got = run_sum(params, inputs, DnnLayers::in_float(), &type, c.then);
    const cv::Mat expected = run_sum(params, inputs, DnnLayers::opencv(), nullptr, c.then);
    const std::string label = cv::dnn::toString(cv::dnn::shape(inputs[0])) + " x" +
                              std::to_string(c.inputs) + (c.then ? std::string(" ") + c.then : "");
    EXPECT_EQ(type, "KeyfleetSum") << label;
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected)) << label;
    EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0) << label;
    if (c.then && std::string(c.then) == "ReLU") {
      double least = 0;
      cv::minMaxLoc(got.reshape(1, 1), &least);
      EXPECT_GE(least, 0) << label;  // the fused activation ran
    }
  }
  std::vector<cv::Mat> inputs(2, cv::Mat({1, 2, 3, 4}, CV_32F, cv::Scalar(2)));
  for (const char* operation : {"prod", "max"}) {
    cv::dnn::LayerParams params;
    params.set("operation", operation);
    std::string type;
    run_sum(params, inputs, DnnLayers::in_float(), &type);
    EXPECT_EQ(type, "Eltwise") << operation;
  }
  cv::dnn::LayerParams weighted;
  weighted.set("operation", "sum");
  const float coeff[] = {1.f, -1.f};
  weighted.set("coeff", cv::dnn::DictValue::arrayReal(coeff, 2));
  std::string type;
  const cv::Mat difference = run_sum(weighted, inputs, DnnLayers::in_float(), &type);
  EXPECT_EQ(type, "Eltwise");
  EXPECT_EQ(cv::norm(difference, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace keyfleet::vision
