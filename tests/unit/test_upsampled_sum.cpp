// A nearest upsampling whose only reader is an element-wise sum run right after it hands the sum
// its input, and the sum adds the widened rows into its output (upsampling_hand_over.hpp, PP-OCR's
// FPN): OpenCV's floats to the bit, either input upsampled, factors 1 to 8, two images, an
// activation fused into the sum; where the sum's output lies over the upsampling's input; not
// where a layer of another branch runs between the two; three inputs (the upsampling written out
// first); set up again for another size outside the scope, and with OpenCV's fusion off.
#include <gtest/gtest.h>

#include <opencv2/dnn/shape_utils.hpp>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {
namespace {

cv::dnn::LayerParams resize(int zoom_y, int zoom_x) {
  cv::dnn::LayerParams p;
  p.type = "Resize";
  p.set("interpolation", "nearest");
  p.set("zoom_factor_y", zoom_y);
  p.set("zoom_factor_x", zoom_x);
  return p;
}

cv::dnn::LayerParams sum() {
  cv::dnn::LayerParams p;
  p.type = "Eltwise";
  p.set("operation", "sum");
  return p;
}

cv::dnn::LayerParams pointwise(cv::RNG& rng, int channels) {
  cv::Mat weights({channels, channels, 1, 1}, CV_32F);
  rng.fill(weights, cv::RNG::UNIFORM, -1.0, 1.0);
  cv::dnn::LayerParams p;
  p.type = "Convolution";
  p.set("num_output", channels);
  p.set("kernel_size", 1);
  p.set("bias_term", false);
  p.blobs = {weights};
  return p;
}

cv::Mat random_blob(cv::RNG& rng, std::vector<int> shape) {
  cv::Mat m(shape, CV_32F);
  rng.fill(m, cv::RNG::UNIFORM, -4.0, 4.0);
  return m;
}

// How the network around the sum is laid out.
struct Layout {
  int zoom_y = 2, zoom_x = 2;
  bool upsampled_first = false;      // the upsampling is the sum's input 0
  const char* activation = nullptr;  // fused into the sum
  bool layer_before = false;         // b goes through a 1x1 layer first (its only reader: the
                                     // upsampling, so the sum's output may take its memory)
  bool branch_between = false;       // a goes through a 1x1 layer whose id lies between the two
  bool third_input = false;          // the sum also adds c (a's shape)
};

struct Outcome {
  cv::Mat out;
  std::string resize_type;
};

// Inputs "a" (the sum's size), "b" (upsampled) and "c" through a network laid out as `layout`,
// with the stand-ins `layers` (none: OpenCV's own).
class SumNetwork {
 public:
  SumNetwork(const Layout& layout, cv::RNG& rng, int channels) : third_(layout.third_input) {
    net_.setInputsNames(third_ ? std::vector<cv::String>{"a", "b", "c"}
                               : std::vector<cv::String>{"a", "b"});
    auto add = [&](const char* name, cv::dnn::LayerParams p) {
      p.name = name;
      return net_.addLayer(name, p.type, p);
    };
    int b = 0, b_pin = 1, a = 0, a_pin = 0;
    if (layout.layer_before) {
      // a through two 1x1 layers first: the first one's output (a's size) dies with the second,
      // the 1x1 layer before the upsampling takes that memory, and it is free again (and large
      // enough for the sum's output) once the upsampling has run.
      const int wide = add("wide", pointwise(rng, channels));
      net_.connect(0, 0, wide, 0);
      a = add("wide_next", pointwise(rng, channels));
      net_.connect(wide, 0, a, 0);
      b = add("before", pointwise(rng, channels));
      net_.connect(0, 1, b, 0);
      b_pin = 0;
    }
    const int up = add("upsampling", resize(layout.zoom_y, layout.zoom_x));
    net_.connect(b, b_pin, up, 0);
    if (layout.branch_between) {
      const int branch = add("branch", pointwise(rng, channels));
      net_.connect(a, a_pin, branch, 0);
      a = branch;
      a_pin = 0;
    }
    const int total = add("sum", sum());
    std::vector<std::pair<int, int>> from = {{a, a_pin}, {up, 0}};
    if (layout.upsampled_first) std::swap(from[0], from[1]);
    if (layout.third_input) from.push_back({0, 2});
    for (std::size_t i = 0; i < from.size(); ++i)
      net_.connect(from[i].first, from[i].second, total, int(i));
    if (layout.activation) {
      cv::dnn::LayerParams p;
      p.type = layout.activation;
      add("activation", p);
      net_.connect(total, 0, net_.getLayerId("activation"), 0);
    }
  }

  Outcome run(const std::vector<cv::Mat>& abc, std::optional<DnnLayers> layers) {
    std::optional<DnnLayersScope> scope;
    if (layers) {
      scope.emplace(*layers);
      scope->watch(net_);
    }
    return run_here(abc);
  }

  Outcome run_here(const std::vector<cv::Mat>& abc) {
    net_.setInput(abc[0], "a");
    net_.setInput(abc[1], "b");
    if (third_) net_.setInput(abc[2], "c");
    Outcome r{net_.forward().clone(), net_.getLayer("upsampling")->type};
    return r;
  }

  cv::dnn::Net& net() { return net_; }

 private:
  bool third_;
  cv::dnn::Net net_;
};

std::vector<cv::Mat> inputs(cv::RNG& rng, int images, int channels, int h, int w,
                            const Layout& layout) {
  return {random_blob(rng, {images, channels, h * layout.zoom_y, w * layout.zoom_x}),
          random_blob(rng, {images, channels, h, w}),
          random_blob(rng, {images, channels, h * layout.zoom_y, w * layout.zoom_x})};
}

// The two stand-ins under test, every other layer OpenCV's (the 1x1 stand-in's sums round
// otherwise).
DnnLayers under_test() {
  DnnLayers layers = DnnLayers::opencv();
  layers.nearest_upsampling = layers.vectorised_sum = true;
  return layers;
}

// The same network (the same weights) with the stand-ins under test and with OpenCV's layers.
void expect_as_opencv(const Layout& layout, int images, int channels, int h, int w,
                      const char* linked_type, const std::string& label) {
  cv::RNG rng(61);
  const std::vector<cv::Mat> abc = inputs(rng, images, channels, h, w, layout);
  cv::RNG weights_a(62), weights_b(62);
  SumNetwork ours(layout, weights_a, channels), theirs(layout, weights_b, channels);
  const Outcome got = ours.run(abc, under_test());
  const Outcome expected = theirs.run(abc, std::nullopt);
  EXPECT_EQ(got.resize_type, linked_type) << label;
  ASSERT_EQ(cv::dnn::shape(got.out), cv::dnn::shape(expected.out)) << label;
  EXPECT_EQ(cv::norm(got.out, expected.out, cv::NORM_INF), 0) << label;
}

TEST(UpsampledSum, MatchesOpenCvsResizeAndEltwise) {
  struct Case {
    int images, channels, h, w, zoom_y, zoom_x;
    bool upsampled_first;
    const char* activation;
  };
  const std::vector<Case> cases = {{1, 96, 15, 20, 2, 2, false, nullptr},
                                   {1, 24, 8, 10, 2, 2, true, nullptr},
                                   {2, 5, 3, 7, 4, 4, false, "ReLU"},
                                   {1, 3, 5, 3, 2, 8, true, "ReLU"},
                                   {1, 4, 6, 5, 1, 1, false, nullptr}};
  for (const Case& c : cases) {
    Layout layout;
    layout.zoom_y = c.zoom_y;
    layout.zoom_x = c.zoom_x;
    layout.upsampled_first = c.upsampled_first;
    layout.activation = c.activation;
    const std::string label = std::to_string(c.images) + "x" + std::to_string(c.channels) + "x" +
                              std::to_string(c.h) + "x" + std::to_string(c.w) + " by " +
                              std::to_string(c.zoom_y) + "," + std::to_string(c.zoom_x) +
                              (c.upsampled_first ? " first" : " second");
    expect_as_opencv(layout, c.images, c.channels, c.h, c.w, "KeyfleetNearestUpsamplingIntoSum",
                     label);
  }
}

TEST(UpsampledSum, AnOutputLaidOverTheUpsamplingsInputStillReadsIt) {
  // The upsampling's input dies with the upsampling in OpenCV's order, so the sum's output (of
  // the same size at factor 1) may take its memory: the sum then upsamples into the waiting blob
  // first, as unfused. The same at factor 2 (an output larger than that memory).
  for (const int zoom : {1, 2}) {
    Layout layout;
    layout.zoom_y = layout.zoom_x = zoom;
    layout.layer_before = true;
    expect_as_opencv(layout, 1, 16, 12, 10, "KeyfleetNearestUpsamplingIntoSum",
                     "factor " + std::to_string(zoom));
  }
}

TEST(UpsampledSum, NotWhereALayerOfAnotherBranchRunsBetween) {
  // The branch's 1x1 layer runs after the upsampling and takes the memory its input held (freed
  // then): handed over, the sum would read that layer's output as the upsampling's input.
  Layout layout;
  layout.branch_between = layout.layer_before = true;
  expect_as_opencv(layout, 1, 16, 12, 10, "KeyfleetNearestUpsampling", "branch between");
}

TEST(UpsampledSum, ThreeInputsHaveTheUpsamplingWrittenFirst) {
  Layout layout;
  layout.third_input = true;
  expect_as_opencv(layout, 2, 6, 5, 7, "KeyfleetNearestUpsamplingIntoSum", "three inputs");
}

TEST(UpsampledSum, SetUpAgainOutsideTheScopeAndWithoutFusion) {
  // OpenCV sets the network up anew for another input size (long after the scope that watched
  // it) and when fusion is turned off: the hand-over is undone and made again (or not) with it.
  Layout layout;
  cv::RNG rng(63), weights_a(64), weights_b(64);
  SumNetwork ours(layout, weights_a, 8), theirs(layout, weights_b, 8);
  ours.run(inputs(rng, 1, 8, 6, 6, layout), under_test());
  const std::vector<cv::Mat> larger = inputs(rng, 1, 8, 9, 11, layout);
  Outcome got = ours.run_here(larger);
  Outcome expected = theirs.run(larger, std::nullopt);
  EXPECT_EQ(got.resize_type, "KeyfleetNearestUpsamplingIntoSum");
  EXPECT_EQ(cv::norm(got.out, expected.out, cv::NORM_INF), 0);
  ours.net().enableFusion(false);
  got = ours.run_here(larger);
  EXPECT_EQ(got.resize_type, "KeyfleetNearestUpsampling");
  EXPECT_EQ(cv::norm(got.out, expected.out, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace keyfleet::vision
