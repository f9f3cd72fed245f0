// A 1x1 stand-in (and the stride-2 first layer's) takes over the depthwise convolution that alone
// reads its large output and runs both a band of rows at a time (banded_depthwise.hpp): OpenCV's
// outputs to float rounding, with the activations after each layer, strides 1 and 2, kernels 3
// and 5, planes whose bands end mid-image, two images; not where the output is small, has a
// second reader, or the stand-ins say no; not where a layer of another branch runs between the
// two (OpenCV lays that branch's blobs over the pair's output: fused, the output came out wrong)
// nor in a network the scope was not told of; and again after OpenCV sets the network up anew for
// another input size, inside the scope or after it. Likewise PP-OCR's DB head: a 2x2 transposed
// convolution and the narrow one after it, band by band.
#include <gtest/gtest.h>

#include <opencv2/dnn/shape_utils.hpp>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {
namespace {

struct Case {
  int cin, channels, h, w, kernel, stride;
  bool depthwise_activation;
};

cv::dnn::LayerParams convolution(const cv::Mat& weights, const cv::Mat& bias, int kernel,
                                 int stride, int group) {
  cv::dnn::LayerParams p;
  p.type = "Convolution";
  p.set("num_output", weights.size[0]);
  p.set("kernel_size", kernel);
  p.set("stride", stride);
  p.set("pad", kernel / 2);
  p.set("group", group);
  p.set("bias_term", !bias.empty());
  p.blobs = {weights};
  if (!bias.empty()) p.blobs.push_back(bias);
  return p;
}

cv::dnn::LayerParams activation(const char* type) {
  cv::dnn::LayerParams p;
  p.type = type;
  if (std::string(type) == "Power") {  // a learnable affine block's scale and shift
    p.set("scale", 0.75f);
    p.set("shift", -0.25f);
  }
  return p;
}

// A chain of named layers through OpenCV DNN with or without keyfleet's stand-ins; `type`: the
// type of the layer named `typed` once the network ran.
using Chain = std::vector<std::pair<std::string, cv::dnn::LayerParams>>;
cv::Mat run_chain(const Chain& chain, const cv::Mat& input, std::optional<DnnLayers> layers,
                  const std::string& typed = "", std::string* type = nullptr) {
  std::optional<DnnLayersScope> scope;
  if (layers) scope.emplace(*layers);
  cv::dnn::Net net;
  for (auto [name, params] : chain) {
    params.name = name;
    net.addLayerToPrev(name, params.type, params);
  }
  if (scope) scope->watch(net);
  net.setInput(input);
  cv::Mat out = net.forward().clone();
  if (type) *type = net.getLayer(typed)->type;
  return out;
}

struct Layers {
  cv::Mat pointwise, pointwise_bias, depthwise, depthwise_bias;
};

// 1x1 -> ReLU -> Power -> depthwise [-> ReLU], optionally with the 1x1 layer's activated output
// also read by a second layer (a sum with the depthwise output, stride 1); `type`: the type of
// the layer that ran the 1x1 convolution.
cv::Mat run(const Layers& l, const Case& c, const cv::Mat& input, std::optional<DnnLayers> layers,
            bool second_reader = false, std::string* type = nullptr,
            const cv::Mat* second_input = nullptr, cv::Mat* second_output = nullptr,
            std::string* second_type = nullptr) {
  std::optional<DnnLayersScope> scope;
  if (layers) scope.emplace(*layers);
  cv::dnn::Net net;
  auto add = [&](const std::string& name, cv::dnn::LayerParams p) {
    p.name = name;
    return net.addLayerToPrev(name, p.type, p);
  };
  add("pointwise", convolution(l.pointwise, l.pointwise_bias, 1, 1, 1));
  add("relu", activation("ReLU"));
  const int affine = add("affine", activation("Power"));
  const int depthwise =
      add("depthwise", convolution(l.depthwise, l.depthwise_bias, c.kernel, c.stride, c.channels));
  if (c.depthwise_activation) add("depthwise_relu", activation("ReLU"));
  if (second_reader) {
    cv::dnn::LayerParams sum;
    sum.name = sum.type = "Eltwise";
    const int id = net.addLayer(sum.name, sum.type, sum);
    net.connect(c.depthwise_activation ? net.getLayerId("depthwise_relu") : depthwise, 0, id, 0);
    net.connect(affine, 0, id, 1);
  }
  if (scope) scope->watch(net);
  net.setInput(input);
  cv::Mat out = net.forward().clone();
  if (type) *type = net.getLayer("pointwise")->type;
  if (second_input) {
    net.setInput(*second_input);
    *second_output = net.forward().clone();
    if (second_type) *second_type = net.getLayer("pointwise")->type;
  }
  return out;
}

Layers random_layers(cv::RNG& rng, const Case& c) {
  Layers l{cv::Mat({c.channels, c.cin, 1, 1}, CV_32F), cv::Mat(1, c.channels, CV_32F),
           cv::Mat({c.channels, 1, c.kernel, c.kernel}, CV_32F), cv::Mat(1, c.channels, CV_32F)};
  for (cv::Mat* m : {&l.pointwise, &l.pointwise_bias, &l.depthwise, &l.depthwise_bias})
    rng.fill(*m, cv::RNG::UNIFORM, -1, 1);
  return l;
}

cv::Mat random_input(cv::RNG& rng, int images, int channels, int h, int w) {
  cv::Mat input({images, channels, h, w}, CV_32F);
  rng.fill(input, cv::RNG::UNIFORM, -2, 2);
  return input;
}

bool supported() { return matrix_product_layers_supported(); }

TEST(BandedDepthwise, MatchesOpenCvsTwoLayers) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // Outputs of 2 MB and more: PP-OCR's 16 -> 32 then 3x3 stride 2 (at 240 x 320 in its detector
  // at 640x480, here smaller and of odd sides), 32 -> 48 then 3x3 stride 1 with an activation,
  // 5x5 kernels both ways, a plane of one band's height and a width that is no whole block.
  const std::vector<Case> cases = {{16, 32, 131, 127, 3, 2, false},
                                   {32, 48, 120, 100, 3, 1, true},
                                   {12, 40, 97, 141, 5, 2, true},
                                   {8, 24, 170, 135, 5, 1, false},
                                   {16, 2048, 4, 67, 3, 2, false}};
  cv::RNG rng(41);
  for (const Case& c : cases) {
    const Layers l = random_layers(rng, c);
    const cv::Mat input = random_input(rng, 2, c.cin, c.h, c.w);
    std::string type;
    const cv::Mat got = run(l, c, input, DnnLayers::in_float(), false, &type);
    EXPECT_EQ(type, "KeyfleetPointwiseDepthwise") << c.cin << " -> " << c.channels;
    const cv::Mat expected = run(l, c, input, DnnLayers::opencv());
    const int side_h = (c.h - 1) / c.stride + 1, side_w = (c.w - 1) / c.stride + 1;
    ASSERT_EQ(cv::dnn::shape(got), (cv::dnn::MatShape{2, c.channels, side_h, side_w}));
    ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
    // Sums of cin products of magnitude <= 2, then k x k of those (<= 2 cin + 1, scaled by
    // 0.75), in another order than OpenCV's.
    const double bound = 1e-6 * (2 * c.cin + 2) * (c.kernel * c.kernel + 1);
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), bound)
        << c.cin << " -> " << c.channels << ", " << c.w << "x" << c.h << ", k " << c.kernel
        << " stride " << c.stride;
  }
}

TEST(BandedDepthwise, AfterTheStride2FirstLayer) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // PP-OCR's first two layers: 3 -> 16, 3x3 stride 2, a batch norm's scale and shift, then a 3x3
  // depthwise layer and its activation (at 640x480 the first output is 4.9 MB); here of odd sides.
  cv::RNG rng(44);
  cv::Mat first({16, 3, 3, 3}, CV_32F), first_bias(1, 16, CV_32F), depthwise({16, 1, 3, 3}, CV_32F),
      depthwise_bias(1, 16, CV_32F);
  for (cv::Mat* m : {&first, &first_bias, &depthwise, &depthwise_bias})
    rng.fill(*m, cv::RNG::UNIFORM, -1, 1);
  const cv::Mat input = random_input(rng, 2, 3, 391, 349);
  const Chain chain = {{"first", convolution(first, first_bias, 3, 2, 1)},
                       {"affine", activation("Power")},
                       {"depthwise", convolution(depthwise, depthwise_bias, 3, 1, 16)},
                       {"relu", activation("ReLU")}};
  auto forward = [&](std::optional<DnnLayers> layers, std::string* type) {
    return run_chain(chain, input, layers, "first", type);
  };
  std::string type;
  const cv::Mat got = forward(DnnLayers::in_float(), &type);
  EXPECT_EQ(type, "KeyfleetStridedDepthwise");
  const cv::Mat expected = forward(DnnLayers::opencv(), nullptr);
  ASSERT_EQ(cv::dnn::shape(got), (cv::dnn::MatShape{2, 16, 196, 175}));
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-6 * 56 * 10);
}

TEST(BandedDepthwise, AnOutputLaidOverTheInputStillReadsTheInput) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // OpenCV lays its blobs out before it fuses: the depthwise layer's output may take the memory
  // of the 1x1 layer's input, dead in the unfused order once the 1x1 layer ran (here an inner
  // layer's output of 16 planes, large enough to hold the 32 half-size ones), while the fused
  // pair still reads it band by band.
  cv::RNG rng(45);
  const Case c{16, 32, 130, 128, 3, 2, false};
  const Layers l = random_layers(rng, c);
  cv::Mat inner({16, 16, 1, 1}, CV_32F), inner_bias(1, 16, CV_32F);
  rng.fill(inner, cv::RNG::UNIFORM, -1, 1);
  rng.fill(inner_bias, cv::RNG::UNIFORM, -1, 1);
  const cv::Mat input = random_input(rng, 1, c.cin, c.h, c.w);
  const Chain chain = {{"inner", convolution(inner, inner_bias, 1, 1, 1)},
                       {"pointwise", convolution(l.pointwise, l.pointwise_bias, 1, 1, 1)},
                       {"relu", activation("ReLU")},
                       {"depthwise", convolution(l.depthwise, l.depthwise_bias, 3, 2, c.channels)}};
  auto forward = [&](std::optional<DnnLayers> layers, std::string* type) {
    return run_chain(chain, input, layers, "pointwise", type);
  };
  std::string type;
  const cv::Mat got = forward(DnnLayers::in_float(), &type);
  EXPECT_EQ(type, "KeyfleetPointwiseDepthwise");
  const cv::Mat expected = forward(DnnLayers::opencv(), nullptr);
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-3);
}

TEST(BandedDepthwise, OnlyWhereTheDepthwiseLayerAloneReadsALargeOutput) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  cv::RNG rng(42);
  const Case large{16, 32, 130, 128, 3, 1, false}, small{16, 32, 60, 64, 3, 2, false};
  DnnLayers off = DnnLayers::in_float();
  off.banded_depthwise = false;
  struct Refusal {
    const Case& c;
    std::optional<DnnLayers> layers;
    bool second_reader;
    const char* why;
  };
  for (const Refusal& r : {Refusal{small, DnnLayers::in_float(), false, "a 0.5 MB output"},
                           Refusal{large, DnnLayers::in_float(), true, "a second reader"},
                           Refusal{large, off, false, "the stand-ins say no"}}) {
    const Layers l = random_layers(rng, r.c);
    const cv::Mat input = random_input(rng, 1, r.c.cin, r.c.h, r.c.w);
    std::string type;
    const cv::Mat got = run(l, r.c, input, r.layers, r.second_reader, &type);
    EXPECT_EQ(type, "KeyfleetPointwise") << r.why;
    const cv::Mat expected = run(l, r.c, input, DnnLayers::opencv(), r.second_reader);
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-4) << r.why;
  }
}

TEST(BandedDepthwise, SetUpAgainForAnotherInputSize) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // OpenCV undoes its fusions (unsetAttached) and fuses again when the input's shape changes:
  // the 1x1 stand-in must neither keep a depthwise layer that now runs on its own (nor say it
  // does) nor apply its activations twice.
  cv::RNG rng(43);
  const Case c{16, 32, 131, 127, 3, 2, true};
  const Layers l = random_layers(rng, c);
  const cv::Mat first = random_input(rng, 1, c.cin, c.h, c.w);
  const cv::Mat second = random_input(rng, 1, c.cin, 40, 36);  // too small to band
  const cv::Mat third = random_input(rng, 1, c.cin, 150, 140);
  for (const cv::Mat* next : {&second, &third}) {
    cv::Mat got_next, expected_next;
    std::string type, type_next;
    const cv::Mat got =
        run(l, c, first, DnnLayers::in_float(), false, &type, next, &got_next, &type_next);
    EXPECT_EQ(type, "KeyfleetPointwiseDepthwise");
    EXPECT_EQ(type_next, next == &second ? "KeyfleetPointwise" : "KeyfleetPointwiseDepthwise");
    const cv::Mat expected =
        run(l, c, first, DnnLayers::opencv(), false, nullptr, next, &expected_next);
    EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-4);
    ASSERT_EQ(cv::dnn::shape(got_next), cv::dnn::shape(expected_next));
    EXPECT_LT(cv::norm(got_next, expected_next, cv::NORM_INF), 1e-4)
        << next->size[3] << "x" << next->size[2];
  }
}

// first -> ReLU -> second, with a branch from the input (branch -> branch_next) whose layers take
// ids between the ReLU and `second`, and a sum of second's and branch_next's outputs: OpenCV lays
// second's output over branch's, which branch_next frees. `type`: first's type once it ran.
struct BranchBetween {
  cv::dnn::LayerParams first, second, branch, branch_next;
};
cv::Mat run_with_branch_between(const BranchBetween& layers_of, const cv::Mat& input,
                                std::optional<DnnLayers> layers, std::string* type) {
  std::optional<DnnLayersScope> scope;
  if (layers) scope.emplace(*layers);
  cv::dnn::Net net;
  auto add = [&](const std::string& name, cv::dnn::LayerParams p, int from) {
    p.name = name;
    const int id = net.addLayer(name, p.type, p);
    net.connect(from, 0, id, 0);
    return id;
  };
  const int relu = add("relu", activation("ReLU"), add("first", layers_of.first, 0));
  const int side = add("branch_next", layers_of.branch_next, add("branch", layers_of.branch, 0));
  const int second = add("second", layers_of.second, relu);
  cv::dnn::LayerParams sum;
  sum.name = sum.type = "Eltwise";
  const int total = net.addLayer(sum.name, sum.type, sum);
  net.connect(second, 0, total, 0);
  net.connect(side, 0, total, 1);
  if (scope) scope->watch(net);
  net.setInput(input);
  cv::Mat out = net.forward().clone();
  if (type) *type = net.getLayer("first")->type;
  return out;
}

TEST(BandedDepthwise, NotWhereALayerOfAnotherBranchRunsBetween) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // OpenCV runs layers in the order of their ids. Here a branch from the input runs between the
  // 1x1 layer and its depthwise reader: `branch` (ids between the two) writes a blob of the
  // depthwise output's size that `branch_next` reads and frees, so OpenCV lays the depthwise
  // output over it. Fused, the pair would write that output first and the branch overwrite it:
  // the stand-in must leave the depthwise layer to run in its own place.
  cv::RNG rng(46);
  const Case c{16, 32, 130, 128, 3, 1, false};
  const Layers l = random_layers(rng, c);
  cv::Mat branch({c.channels, c.cin, 1, 1}, CV_32F), branch_bias(1, c.channels, CV_32F),
      next({c.channels, c.channels, 1, 1}, CV_32F), next_bias(1, c.channels, CV_32F);
  for (cv::Mat* m : {&branch, &branch_bias, &next, &next_bias})
    rng.fill(*m, cv::RNG::UNIFORM, -1, 1);
  const cv::Mat input = random_input(rng, 1, c.cin, c.h, c.w);
  const BranchBetween net{convolution(l.pointwise, l.pointwise_bias, 1, 1, 1),
                          convolution(l.depthwise, l.depthwise_bias, 3, 1, c.channels),
                          convolution(branch, branch_bias, 1, 1, 1),
                          convolution(next, next_bias, 1, 1, 1)};
  auto forward = [&](std::optional<DnnLayers> layers, std::string* type) {
    return run_with_branch_between(net, input, layers, type);
  };
  std::string type;
  const cv::Mat got = forward(DnnLayers::in_float(), &type);
  EXPECT_EQ(type, "KeyfleetPointwise");
  const cv::Mat expected = forward(DnnLayers::opencv(), nullptr);
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-3);
}

TEST(BandedDepthwise, NotForANetworkTheScopeWasNotToldOf) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // Without the network the stand-in cannot read OpenCV's order: it takes nothing over.
  cv::RNG rng(47);
  const Case c{16, 32, 130, 128, 3, 1, false};
  const Layers l = random_layers(rng, c);
  const cv::Mat input = random_input(rng, 1, c.cin, c.h, c.w);
  const Chain chain = {{"pointwise", convolution(l.pointwise, l.pointwise_bias, 1, 1, 1)},
                       {"depthwise", convolution(l.depthwise, l.depthwise_bias, 3, 1, c.channels)}};
  DnnLayersScope scope(DnnLayers::in_float());
  cv::dnn::Net net;
  for (auto [name, params] : chain) {
    params.name = name;
    net.addLayerToPrev(name, params.type, params);
  }
  net.setInput(input);
  const cv::Mat got = net.forward().clone();
  EXPECT_EQ(net.getLayer("pointwise")->type, "KeyfleetPointwise");
  EXPECT_EQ(cv::dnn::shape(got), (cv::dnn::MatShape{1, c.channels, c.h, c.w}));
}

TEST(BandedDepthwise, KeepsItsDecisionWhenSetUpAgainOutsideTheScope) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // OpenCV fuses again when the input's shape changes, which may happen long after the scope
  // that watched the network ended: the pair found to run one after the other fuses again.
  cv::RNG rng(48);
  const Case c{16, 32, 130, 128, 3, 1, false};
  const Layers l = random_layers(rng, c);
  const cv::Mat first = random_input(rng, 1, c.cin, c.h, c.w);
  const cv::Mat second = random_input(rng, 1, c.cin, 150, 140);
  const Chain chain = {{"pointwise", convolution(l.pointwise, l.pointwise_bias, 1, 1, 1)},
                       {"relu", activation("ReLU")},
                       {"depthwise", convolution(l.depthwise, l.depthwise_bias, 3, 1, c.channels)}};
  cv::dnn::Net net;
  {
    DnnLayersScope scope(DnnLayers::in_float());
    for (auto [name, params] : chain) {
      params.name = name;
      net.addLayerToPrev(name, params.type, params);
    }
    scope.watch(net);
    net.setInput(first);
    net.forward();
    EXPECT_EQ(net.getLayer("pointwise")->type, "KeyfleetPointwiseDepthwise");
  }
  net.setInput(second);
  const cv::Mat got = net.forward().clone();
  EXPECT_EQ(net.getLayer("pointwise")->type, "KeyfleetPointwiseDepthwise");
  const cv::Mat expected = run_chain(chain, second, DnnLayers::opencv());
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-4);
}

cv::dnn::LayerParams transposed_2x2(const cv::Mat& weights, const cv::Mat& bias) {
  cv::dnn::LayerParams p;
  p.type = "Deconvolution";
  p.set("num_output", weights.size[1]);
  const int kernel[] = {2, 2}, stride[] = {2, 2}, pads[] = {0, 0, 0, 0}, adjust[] = {0, 0};
  p.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
  p.set("stride", cv::dnn::DictValue::arrayInt(stride, 2));
  p.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
  p.set("adj", cv::dnn::DictValue::arrayInt(adjust, 2));
  p.set("bias_term", true);
  p.blobs = {weights, bias};
  return p;
}

TEST(SubpixelDeconvolutionPair, MatchesOpenCvsDbHead) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // 24 -> 24 -> 1 (and -> 2), ReLU between and Sigmoid after, 2 MB or more of first output, an
  // odd number of rows (the last band shorter); after an inner layer whose output the pair's
  // output may be laid over (as in PP-OCR's detector at 640x480, where it is).
  cv::RNG rng(46);
  for (const int narrow : {1, 2})
    for (const bool inner_first : {false, true}) {
      cv::Mat inner({24, 24, 1, 1}, CV_32F), inner_bias(1, 24, CV_32F),
          wide({24, 24, 2, 2}, CV_32F), wide_bias(1, 24, CV_32F), last({24, narrow, 2, 2}, CV_32F),
          last_bias(1, narrow, CV_32F);
      for (cv::Mat* m : {&inner, &inner_bias, &wide, &wide_bias, &last, &last_bias})
        rng.fill(*m, cv::RNG::UNIFORM, -1, 1);
      const cv::Mat input = random_input(rng, 2, 24, 117, 160);
      Chain chain;
      if (inner_first) chain.push_back({"inner", convolution(inner, inner_bias, 1, 1, 1)});
      chain.push_back({"wide", transposed_2x2(wide, wide_bias)});
      chain.push_back({"relu", activation("ReLU")});
      chain.push_back({"narrow", transposed_2x2(last, last_bias)});
      chain.push_back({"sigmoid", activation("Sigmoid")});
      auto forward = [&](std::optional<DnnLayers> layers, std::string* type) {
        return run_chain(chain, input, layers, "wide", type);
      };
      std::string type;
      const cv::Mat got = forward(DnnLayers::in_float(), &type);
      EXPECT_EQ(type, "KeyfleetSubpixelDeconvolutionPair");
      const cv::Mat expected = forward(DnnLayers::opencv(), nullptr);
      ASSERT_EQ(cv::dnn::shape(got), (cv::dnn::MatShape{2, narrow, 468, 640}));
      ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
      EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-5)
          << "24 -> 24 -> " << narrow << (inner_first ? " after an inner layer" : "");
    }
}

TEST(SubpixelDeconvolutionPair, NotWhereALayerOfAnotherBranchRunsBetween) {
  if (!supported()) GTEST_SKIP() << "no AVX2 + FMA: OpenCV's layers stay";
  // As BandedDepthwise's: a branch from the input runs between the two transposed layers and
  // frees a blob of the pair's output size, which OpenCV lays the narrow layer's output over.
  cv::RNG rng(49);
  cv::Mat wide({24, 24, 2, 2}, CV_32F), wide_bias(1, 24, CV_32F), last({24, 1, 2, 2}, CV_32F),
      last_bias(1, 1, CV_32F), branch({24, 1, 4, 4}, CV_32F), branch_bias(1, 1, CV_32F),
      next({1, 1, 1, 1}, CV_32F), next_bias(1, 1, CV_32F);
  for (cv::Mat* m :
       {&wide, &wide_bias, &last, &last_bias, &branch, &branch_bias, &next, &next_bias})
    rng.fill(*m, cv::RNG::UNIFORM, -1, 1);
  cv::dnn::LayerParams by4 = transposed_2x2(branch, branch_bias);
  const int kernel[] = {4, 4}, stride[] = {4, 4};
  by4.set("kernel_size", cv::dnn::DictValue::arrayInt(kernel, 2));
  by4.set("stride", cv::dnn::DictValue::arrayInt(stride, 2));
  const cv::Mat input = random_input(rng, 1, 24, 117, 160);
  const BranchBetween net{transposed_2x2(wide, wide_bias), transposed_2x2(last, last_bias), by4,
                          convolution(next, next_bias, 1, 1, 1)};
  auto forward = [&](std::optional<DnnLayers> layers, std::string* type) {
    return run_with_branch_between(net, input, layers, type);
  };
  std::string type;
  const cv::Mat got = forward(DnnLayers::in_float(), &type);
  EXPECT_NE(type, "KeyfleetSubpixelDeconvolutionPair");
  const cv::Mat expected = forward(DnnLayers::opencv(), nullptr);
  ASSERT_EQ(cv::dnn::shape(got), (cv::dnn::MatShape{1, 1, 468, 640}));
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-4);
}

}  // namespace
}  // namespace keyfleet::vision
