// A float 1x1 convolution whose output only a global average pooling and a channel scaling read,
// the scaling's only an element-wise sum (PP-OCR's RSE layers, pointwise_hand_over.hpp): the sum
// computes the scaled convolution with its other input added, neither output written; OpenCV's
// outputs to float rounding with the other input upsampled by 2, 4 or 1 each way, or plain; and
// where the hand-over cannot be taken whole: the scaling's output read by another layer too (the
// scaling writes it), the convolution's read by a layer that knows no hand-over (nothing handed
// over), the sum reading a second 1x1 layer that hands nothing over; set up again for another size
// outside the scope. (Two images: OpenCV 4.6's own Scale layer refuses a gate per image, so no such
// network runs.)
#include <gtest/gtest.h>

#include <opencv2/dnn/shape_utils.hpp>

#include <optional>
#include <string>
#include <vector>

#include "keyfleet/vision/dnn_layers.hpp"

namespace keyfleet::vision {
namespace {

cv::Mat random_blob(cv::RNG& rng, std::vector<int> shape, double range = 1.0) {
  cv::Mat m(shape, CV_32F);
  rng.fill(m, cv::RNG::UNIFORM, -range, range);
  return m;
}

cv::dnn::LayerParams pointwise(cv::RNG& rng, int inputs, int outputs) {
  cv::dnn::LayerParams p;
  p.type = "Convolution";
  p.set("num_output", outputs);
  p.set("kernel_size", 1);
  p.set("bias_term", true);
  p.blobs = {random_blob(rng, {outputs, inputs, 1, 1}), random_blob(rng, {outputs})};
  return p;
}

cv::dnn::LayerParams of_type(const char* type) {
  cv::dnn::LayerParams p;
  p.type = type;
  return p;
}

// How the network around the sum is laid out.
struct Layout {
  int zoom = 2;                  // the sum's other input: "t" upsampled so (0: "t" itself)
  bool scaled_read_too = false;  // a ReLU reads the scaling's output as well
  bool conv_read_too = false;    // a ReLU reads the convolution's output as well
  bool other_by_conv = false;    // the sum's other input: a 1x1 layer of "t" (zoom 0)
};

// m (12 channels) -> 1x1 (C) = x; gate = 1 + sigmoid(1x1(relu(1x1(pool(x))))); sum = x * gate
// + up(t), plus any extra reader's output.
class ExcitedNetwork {
 public:
  ExcitedNetwork(const Layout& layout, int channels) : layout_(layout) {
    cv::RNG rng(73);
    net_.setInputsNames({"m", "t"});
    const auto add = [&](const char* name, cv::dnn::LayerParams p, std::vector<int> from) {
      p.name = name;
      const int id = net_.addLayer(name, p.type, p);
      for (std::size_t i = 0; i < from.size(); i += 2)
        net_.connect(from[i], from[i + 1], id, int(i / 2));
      return id;
    };
    const int conv = add("conv", pointwise(rng, 12, channels), {0, 0});
    cv::dnn::LayerParams pool = of_type("Pooling");
    pool.set("global_pooling", true);
    pool.set("pool", "ave");
    const int pooled = add("pool", pool, {conv, 0});
    const int squeezed = add("squeeze", pointwise(rng, channels, channels / 4), {pooled, 0});
    const int relu = add("relu", of_type("ReLU"), {squeezed, 0});
    const int excited = add("excite", pointwise(rng, channels / 4, channels), {relu, 0});
    const int gate = add("gate", of_type("Sigmoid"), {excited, 0});
    cv::dnn::LayerParams power = of_type("Power");
    power.set("shift", 1.f);
    const int plus_one = add("plus_one", power, {gate, 0});
    int conv_extra = -1;
    if (layout.conv_read_too) conv_extra = add("conv_extra", of_type("ReLU"), {conv, 0});
    cv::dnn::LayerParams scale = of_type("Scale");
    scale.set("bias_term", false);
    scale.set("axis", 1);
    const int scaled = add("scale", scale, {conv, 0, plus_one, 0});
    int scaled_extra = -1;
    if (layout.scaled_read_too) scaled_extra = add("scaled_extra", of_type("ReLU"), {scaled, 0});
    int other = 0, other_pin = 1;
    if (layout.other_by_conv) {
      other = add("other_conv", pointwise(rng, channels, channels), {0, 1});
      other_pin = 0;
    } else if (layout.zoom > 0) {
      cv::dnn::LayerParams up = of_type("Resize");
      up.set("interpolation", "nearest");
      up.set("zoom_factor_y", layout.zoom);
      up.set("zoom_factor_x", layout.zoom);
      other = add("up", up, {0, 1});
      other_pin = 0;
    }
    cv::dnn::LayerParams sum = of_type("Eltwise");
    sum.set("operation", "sum");
    int last = add("sum", sum, {scaled, 0, other, other_pin});
    for (const int extra : {conv_extra, scaled_extra})
      if (extra >= 0)
        last = add(extra == conv_extra ? "total_a" : "total_b", sum, {last, 0, extra, 0});
  }

  cv::Mat run(const cv::Mat& m, const cv::Mat& t, std::optional<DnnLayers> layers) {
    std::optional<DnnLayersScope> scope;
    if (layers) {
      scope.emplace(*layers);
      scope->watch(net_);
    }
    return run_here(m, t);
  }

  cv::Mat run_here(const cv::Mat& m, const cv::Mat& t) {
    net_.setInput(m, "m");
    net_.setInput(t, "t");
    return net_.forward().clone();
  }

  std::string type(const char* layer) { return net_.getLayer(layer)->type; }

 private:
  Layout layout_;
  cv::dnn::Net net_;
};

// The stand-ins under test, every other layer OpenCV's.
DnnLayers under_test(bool excited_sums) {
  DnnLayers layers = DnnLayers::opencv();
  layers.pointwise = layers.global_average_pool = layers.vectorised_sum = true;
  layers.nearest_upsampling = true;
  layers.excited_sums = excited_sums;
  return layers;
}

struct Inputs {
  cv::Mat m, t;
};

Inputs inputs(int images, int channels, int h, int w, int zoom) {
  cv::RNG rng(74);
  const int scale = zoom > 0 ? zoom : 1;
  return {random_blob(rng, {images, 12, h, w}),
          random_blob(rng, {images, channels, h / scale, w / scale}, 4.0)};
}

void expect_near(const cv::Mat& got, const cv::Mat& expected, const std::string& label) {
  ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected)) << label;
  const double spread = std::max(1.0, cv::norm(expected, cv::NORM_INF));
  EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 2e-5 * spread) << label;
}

TEST(ExcitedSum, TheSumComputesTheScaledConvolutionAsOpenCvDoes) {
  struct Case {
    int channels, h, w, zoom;
  };
  // PP-OCR's finest level at 640x480 (96 x 120 x 160), odd widths, factors 4 and 1, plain.
  for (const Case& c : {Case{96, 120, 160, 2}, Case{24, 10, 14, 2}, Case{12, 8, 24, 4},
                        Case{48, 6, 10, 1}, Case{48, 7, 9, 0}}) {
    const std::string label = std::to_string(c.channels) + "x" + std::to_string(c.h) + "x" +
                              std::to_string(c.w) + " zoom " + std::to_string(c.zoom);
    Layout layout;
    layout.zoom = c.zoom;
    const Inputs in = inputs(1, c.channels, c.h, c.w, c.zoom);
    ExcitedNetwork ours(layout, c.channels), theirs(layout, c.channels);
    const cv::Mat got = ours.run(in.m, in.t, under_test(true));
    EXPECT_EQ(ours.type("scale"), "KeyfleetScaleHandedOver") << label;
    EXPECT_EQ(ours.type("conv"), "KeyfleetPointwiseHandedOver") << label;
    expect_near(got, theirs.run(in.m, in.t, std::nullopt), label);
    // Again: the hand-over is set afresh on every pass.
    expect_near(ours.run_here(in.m, in.t), got, label + " again");
  }
}

TEST(ExcitedSum, AScaledOutputReadByAnotherLayerIsWrittenByTheScaling) {
  Layout layout;
  layout.scaled_read_too = true;
  const Inputs in = inputs(1, 24, 12, 16, 2);
  ExcitedNetwork ours(layout, 24), theirs(layout, 24);
  const cv::Mat got = ours.run(in.m, in.t, under_test(true));
  EXPECT_EQ(ours.type("scale"), "KeyfleetScale");
  expect_near(got, theirs.run(in.m, in.t, std::nullopt), "scaled output read twice");
}

TEST(ExcitedSum, AConvolutionReadByALayerThatKnowsNoHandOverWritesItsOutput) {
  Layout layout;
  layout.conv_read_too = true;
  const Inputs in = inputs(1, 24, 12, 16, 2);
  ExcitedNetwork ours(layout, 24), theirs(layout, 24);
  const cv::Mat got = ours.run(in.m, in.t, under_test(true));
  EXPECT_EQ(ours.type("scale"), "KeyfleetScale");
  EXPECT_EQ(ours.type("conv"), "KeyfleetPointwise");
  expect_near(got, theirs.run(in.m, in.t, std::nullopt), "convolution read by a ReLU");
}

// The sum also reads another 1x1 layer, whose only reader it is (no scaling: not handed over, as
// MiniNet's residual blocks): that layer leaves the sum the other's hand-over.
TEST(ExcitedSum, ASumReadingTwoConvolutionsTakesTheOneHandedOver) {
  Layout layout;
  layout.zoom = 0;
  layout.other_by_conv = true;
  const Inputs in = inputs(1, 24, 12, 16, 0);
  ExcitedNetwork ours(layout, 24), theirs(layout, 24);
  const cv::Mat got = ours.run(in.m, in.t, under_test(true));
  EXPECT_EQ(ours.type("conv"), "KeyfleetPointwiseHandedOver");
  EXPECT_EQ(ours.type("other_conv"), "KeyfleetPointwise");
  EXPECT_EQ(ours.type("scale"), "KeyfleetScaleHandedOver");
  expect_near(got, theirs.run(in.m, in.t, std::nullopt), "two convolutions into the sum");
}

TEST(ExcitedSum, OffItIsTheLayersOneByOne) {
  const Inputs in = inputs(1, 96, 24, 32, 2);
  ExcitedNetwork on({}, 96), off({}, 96);
  const cv::Mat fused = on.run(in.m, in.t, under_test(true));
  const cv::Mat unfused = off.run(in.m, in.t, under_test(false));
  EXPECT_EQ(off.type("scale"), "Scale");  // OpenCV's own
  expect_near(fused, unfused, "excited_sums off");
}

TEST(ExcitedSum, SetUpAgainForAnotherSizeOutsideTheScope) {
  ExcitedNetwork ours({}, 24), theirs({}, 24);
  const Inputs first = inputs(1, 24, 12, 16, 2);
  ours.run(first.m, first.t, under_test(true));
  theirs.run(first.m, first.t, std::nullopt);
  const Inputs second = inputs(1, 24, 20, 30, 2);
  const cv::Mat got = ours.run_here(second.m, second.t);
  EXPECT_EQ(ours.type("scale"), "KeyfleetScaleHandedOver");
  expect_near(got, theirs.run_here(second.m, second.t), "another size");
}

}  // namespace
}  // namespace keyfleet::vision
