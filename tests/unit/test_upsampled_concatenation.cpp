// A 3x3 convolution that alone reads a concatenation of nearest upsamplings (PP-OCR's DB head)
// takes the upsamplings by 4 or more at their own size (upsampled_concatenation.hpp): OpenCV's
// outputs to float rounding at the head's geometry, with factors that differ by direction,
// sources one row or column high, an activation fused in; and where it cannot take them (two
// images, the channels written in place not one run or fewer than 8, 4 outputs, the concatenation
// read by another layer too, the convolution in bfloat16, set up again outside the scope or without
// fusion) still OpenCV's outputs.
#include <gtest/gtest.h>

#include <opencv2/dnn/shape_utils.hpp>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {
namespace {

cv::Mat random_blob(cv::RNG& rng, std::vector<int> shape, double range = 4.0) {
  cv::Mat m(shape, CV_32F);
  rng.fill(m, cv::RNG::UNIFORM, -range, range);
  return m;
}

cv::dnn::LayerParams convolution(cv::RNG& rng, int inputs, int outputs, int k) {
  cv::dnn::LayerParams p;
  p.type = "Convolution";
  p.set("num_output", outputs);
  p.set("kernel_size", k);
  p.set("pad", k / 2);
  p.set("bias_term", true);
  p.blobs = {random_blob(rng, {outputs, inputs, k, k}, 0.3), random_blob(rng, {outputs}, 1.0)};
  return p;
}

// One input of the concatenation: `channels` at the output's size divided by the factors (1, 1:
// the branch written in place, through a 1x1 layer as PP-OCR's is).
struct Part {
  int channels, zoom_y, zoom_x;
};

struct Layout {
  std::vector<Part> parts;
  int outputs = 24;
  const char* activation = "ReLU";
  bool second_reader = false;  // a 1x1 layer reads the concatenation too
};

struct Outcome {
  cv::Mat out;
  std::vector<std::string> resize_types;
};

class ConcatenationNetwork {
 public:
  ConcatenationNetwork(const Layout& layout, cv::RNG& rng) : layout_(layout) {
    std::vector<cv::String> names;
    for (std::size_t i = 0; i < layout.parts.size(); ++i) names.push_back(name(i));
    net_.setInputsNames(names);
    int channels = 0;
    std::vector<int> from;
    for (std::size_t i = 0; i < layout.parts.size(); ++i) {
      const Part& part = layout.parts[i];
      channels += part.channels;
      cv::dnn::LayerParams p;
      if (part.zoom_y == 1 && part.zoom_x == 1) {
        p = convolution(rng, part.channels, part.channels, 1);
      } else {
        p.type = "Resize";
        p.set("interpolation", "nearest");
        p.set("zoom_factor_y", part.zoom_y);
        p.set("zoom_factor_x", part.zoom_x);
      }
      p.name = "in_" + name(i);
      from.push_back(net_.addLayer(p.name, p.type, p));
      net_.connect(0, int(i), from.back(), 0);
    }
    cv::dnn::LayerParams concat;
    concat.type = "Concat";
    concat.set("axis", 1);
    const int joined = net_.addLayer("concat", concat.type, concat);
    for (std::size_t i = 0; i < from.size(); ++i) net_.connect(from[i], 0, joined, int(i));
    cv::dnn::LayerParams head = convolution(rng, channels, layout.outputs, 3);
    const int conv = net_.addLayer("head", head.type, head);
    net_.connect(joined, 0, conv, 0);
    int last = conv;
    if (layout.activation) {
      cv::dnn::LayerParams p;
      p.type = layout.activation;
      last = net_.addLayer("activation", p.type, p);
      net_.connect(conv, 0, last, 0);
    }
    if (layout.second_reader) {
      cv::dnn::LayerParams other = convolution(rng, channels, layout.outputs, 1);
      const int second = net_.addLayer("second", other.type, other);
      net_.connect(joined, 0, second, 0);
      cv::dnn::LayerParams sum;
      sum.type = "Eltwise";
      sum.set("operation", "sum");
      const int total = net_.addLayer("sum", sum.type, sum);
      net_.connect(last, 0, total, 0);
      net_.connect(second, 0, total, 1);
    }
  }

  std::vector<cv::Mat> inputs(cv::RNG& rng, int images, int h, int w) const {
    std::vector<cv::Mat> out;
    for (const Part& p : layout_.parts)
      out.push_back(random_blob(rng, {images, p.channels, h / p.zoom_y, w / p.zoom_x}));
    return out;
  }

  Outcome run(const std::vector<cv::Mat>& in, std::optional<DnnLayers> layers) {
    std::optional<DnnLayersScope> scope;
    if (layers) {
      scope.emplace(*layers);
      scope->watch(net_);
    }
    return run_here(in);
  }

  Outcome run_here(const std::vector<cv::Mat>& in) {
    for (std::size_t i = 0; i < in.size(); ++i) net_.setInput(in[i], name(i));
    Outcome r{net_.forward().clone(), {}};
    for (std::size_t i = 0; i < layout_.parts.size(); ++i)
      if (layout_.parts[i].zoom_y > 1 || layout_.parts[i].zoom_x > 1)
        r.resize_types.push_back(net_.getLayer("in_" + name(i))->type);
    return r;
  }

  cv::dnn::Net& net() { return net_; }

 private:
  static std::string name(std::size_t i) { return "x" + std::to_string(i); }
  Layout layout_;
  cv::dnn::Net net_;
};

// The stand-ins under test (the upsampling, the 3x3 layer), every other layer OpenCV's.
DnnLayers under_test() {
  DnnLayers layers = DnnLayers::opencv();
  layers.nearest_upsampling = layers.dense_3x3 = layers.upsampled_taps = true;
  return layers;
}

// Within float rounding of OpenCV's (Winograd's transforms and another order of sums).
void expect_close(const cv::Mat& got, const cv::Mat& expected, const std::string& label) {
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected)) << label;
  const double spread = std::max(1.0, cv::norm(expected, cv::NORM_INF));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 2e-5 * spread) << label;
}

// Runs `layout` with the stand-ins and with OpenCV's layers; returns the resizes' types.
std::vector<std::string> expect_as_opencv(const Layout& layout, int images, int h, int w,
                                          const std::string& label) {
  cv::RNG rng(71), weights_a(72), weights_b(72);
  ConcatenationNetwork ours(layout, weights_a), theirs(layout, weights_b);
  const std::vector<cv::Mat> in = ours.inputs(rng, images, h, w);
  const Outcome got = ours.run(in, under_test());
  const Outcome expected = theirs.run(in, std::nullopt);
  expect_close(got.out, expected.out, label);
  return got.resize_types;
}

const std::vector<std::string> kHanded = {"KeyfleetNearestUpsamplingIntoConvolution",
                                          "KeyfleetNearestUpsamplingIntoConvolution",
                                          "KeyfleetNearestUpsampling"};

TEST(UpsampledConcatenation, TheDbHeadsLevelsMatchOpenCv) {
  // PP-OCR's head at 256x192 (the agent's detector): levels by 8, 4 and 2, then the one at 1/4.
  Layout layout;
  layout.parts = std::vector<Part>{{24, 8, 8}, {24, 4, 4}, {24, 2, 2}, {24, 1, 1}};
  EXPECT_EQ(expect_as_opencv(layout, 1, 48, 64, "head 48x64"), kHanded);
  layout.activation = nullptr;
  EXPECT_EQ(expect_as_opencv(layout, 1, 48, 64, "head without activation"), kHanded);
}

TEST(UpsampledConcatenation, FactorsByDirectionAndSourcesOneRowHigh) {
  struct Case {
    int h, w;
    std::vector<Part> parts;
  };
  const std::vector<Case> cases = {
      {8, 16, {{5, 8, 4}, {8, 1, 1}, {3, 4, 16}}},   // sources 1 x 4 and 2 x 1
      {16, 8, {{4, 16, 8}, {9, 1, 1}}},              // a source of one pixel
      {24, 40, {{7, 4, 8}, {6, 8, 4}, {12, 1, 1}}},  // odd channel counts
  };
  for (const Case& c : cases) {
    Layout layout;
    layout.parts = c.parts;
    layout.outputs = 10;
    const std::string label = std::to_string(c.h) + "x" + std::to_string(c.w);
    for (const std::string& type : expect_as_opencv(layout, 1, c.h, c.w, label))
      EXPECT_EQ(type, "KeyfleetNearestUpsamplingIntoConvolution") << label;
  }
}

TEST(UpsampledConcatenation, WhatItCannotTakeIsWrittenFirst) {
  // Two images; the channels written in place split in two runs; only 6 of them; 4 outputs.
  Layout two_images;
  two_images.parts = std::vector<Part>{{8, 4, 4}, {16, 1, 1}};
  expect_as_opencv(two_images, 2, 16, 16, "two images");
  Layout split;
  split.parts = std::vector<Part>{{8, 1, 1}, {8, 4, 4}, {8, 1, 1}};
  expect_as_opencv(split, 1, 16, 16, "split");
  Layout few;
  few.parts = std::vector<Part>{{8, 4, 4}, {6, 1, 1}};
  expect_as_opencv(few, 1, 16, 16, "six in place");
  Layout narrow;
  narrow.parts = std::vector<Part>{{8, 4, 4}, {16, 1, 1}};
  narrow.outputs = 4;
  expect_as_opencv(narrow, 1, 16, 16, "four outputs");
}

TEST(UpsampledConcatenation, NotWhereAnotherLayerReadsTheConcatenation) {
  Layout layout;
  layout.parts = std::vector<Part>{{8, 4, 4}, {16, 1, 1}};
  layout.second_reader = true;
  EXPECT_EQ(expect_as_opencv(layout, 1, 16, 16, "second reader"),
            std::vector<std::string>{"KeyfleetNearestUpsampling"});
}

TEST(UpsampledConcatenation, AConvolutionInBfloat16TakesNoSlices) {
  // Where the CPU multiplies in bfloat16 the 3x3 layer does so and leaves the upsamplings to
  // write their slices (outputs within bfloat16's rounding); elsewhere it stays in float and
  // takes them.
  Layout layout;
  layout.parts = std::vector<Part>{{24, 8, 8}, {24, 4, 4}, {24, 2, 2}, {24, 1, 1}};
  DnnLayers layers = under_test();
  layers.bfloat16_products = true;
  cv::RNG rng(75), weights_a(76), weights_b(76);
  ConcatenationNetwork ours(layout, weights_a), theirs(layout, weights_b);
  const std::vector<cv::Mat> in = ours.inputs(rng, 1, 48, 64);
  const Outcome got = ours.run(in, layers);
  const Outcome expected = theirs.run(in, std::nullopt);
  ASSERT_EQ(cv::dnn::shape(got.out), cv::dnn::shape(expected.out));
  const double spread = std::max(1.0, cv::norm(expected.out, cv::NORM_INF));
  if (bfloat16_products_supported()) {
    EXPECT_EQ(got.resize_types, std::vector<std::string>(3, "KeyfleetNearestUpsampling"));
    EXPECT_LT(cv::norm(got.out, expected.out, cv::NORM_INF), 0.02 * spread);
  } else {
    EXPECT_EQ(got.resize_types, kHanded);
    EXPECT_LT(cv::norm(got.out, expected.out, cv::NORM_INF), 2e-5 * spread);
  }
}

TEST(UpsampledConcatenation, SetUpAgainOutsideTheScopeAndWithoutFusion) {
  Layout layout;
  layout.parts = std::vector<Part>{{24, 8, 8}, {24, 4, 4}, {24, 2, 2}, {24, 1, 1}};
  cv::RNG rng(73), weights_a(74), weights_b(74);
  ConcatenationNetwork ours(layout, weights_a), theirs(layout, weights_b);
  ours.run(ours.inputs(rng, 1, 24, 32), under_test());
  const std::vector<cv::Mat> larger = ours.inputs(rng, 1, 48, 64);
  Outcome got = ours.run_here(larger);
  const Outcome expected = theirs.run(larger, std::nullopt);
  EXPECT_EQ(got.resize_types, kHanded);
  expect_close(got.out, expected.out, "set up again");
  ours.net().enableFusion(false);
  got = ours.run_here(larger);
  EXPECT_EQ(got.resize_types, std::vector<std::string>(3, "KeyfleetNearestUpsampling"));
  expect_close(got.out, expected.out, "without fusion");
}

}  // namespace
}  // namespace keyfleet::vision
