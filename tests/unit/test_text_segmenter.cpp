// The semantic seam: the ONNX text segmenter loads its fixture, gives one mask per frame,
// refuses broken or unusable models with a StartupError naming the file; the text score
// prefers text away from the frame border; keyfleet's SELU and depthwise convolution compute
// what OpenCV's do.
#include <gtest/gtest.h>

#include <opencv2/dnn/shape_utils.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/agent/semantic_score.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/text_segmenter.hpp"
#include "test_support.hpp"

namespace keyfleet::vision {
namespace {

using agent::semantic_score;

namespace fs = std::filesystem;

const fs::path kFixtures = KEYFLEET_FIXTURES;

std::string fixture(const std::string& name) { return (kFixtures / name).string(); }

std::vector<char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), {});
}

void write_bytes(const std::string& path, const char* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary);
  out.write(data, std::streamsize(size));
}

// The message of the StartupError that loading `model` throws ("" when none is thrown).
std::string startup_error_of(const std::string& model) {
  try {
    DnnTextSegmenter segmenter(model, 1);
  } catch (const StartupError& e) {
    return e.what();
  }
  return "";
}

// Dark words on a light sign: the high-contrast strokes a text detector must respond to.
cv::Mat make_text_image(int width, int height) {
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(235, 235, 235));
  cv::putText(image, "PHARMACY", {width / 12, height / 2}, cv::FONT_HERSHEY_SIMPLEX, width / 300.0,
              cv::Scalar(10, 10, 10), 3, cv::LINE_AA);
  cv::putText(image, "open 9-18", {width / 12, 4 * height / 5}, cv::FONT_HERSHEY_PLAIN,
              width / 250.0, cv::Scalar(20, 20, 160), 2, cv::LINE_AA);
  return image;
}

// --- vectorised SELU --------------------------------------------------------------------------

TEST(VectorisedSelu, MatchesTheFormulaInDoublePrecisionWithinFloatRounding) {
  const float alpha = 1.6732632423543772f, gamma = 1.0507009873554805f;
  std::vector<float> x;
  for (float v = -90.f; v <= 90.f; v += 0.0137f) x.push_back(v);
  x.insert(x.end(), {0.f, -0.f, 1e-30f, -1e-30f, -1e-7f});
  x.resize(x.size() | 1);  // an odd length: a tail shorter than a SIMD register
  std::vector<float> y(x.size());
  selu_vectorised(x.data(), y.data(), int(x.size()), alpha, gamma);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double v = x[i];
    const double expected = gamma * (v > 0 ? v : alpha * std::expm1(v));
    ASSERT_NEAR(y[i], expected, 1e-6 + 2e-7 * std::abs(expected)) << "x = " << v;
  }
}

TEST(VectorisedSelu, RunsInPlace) {
  std::vector<float> x = {-3.f, -0.5f, 0.f, 0.25f, 7.f}, y(x.size());
  selu_vectorised(x.data(), y.data(), int(x.size()), 1.5f, 1.1f);
  selu_vectorised(x.data(), x.data(), int(x.size()), 1.5f, 1.1f);
  EXPECT_EQ(x, y);
}

// One convolution layer through OpenCV DNN, with or without keyfleet's stand-ins.
// `type`: the class of layer that ran it.
cv::Mat convolve(const cv::Mat& input, const cv::Mat& weights, const cv::Mat& bias,
                 cv::dnn::LayerParams params, DnnLayers layers, std::string* type = nullptr) {
  params.type = "Convolution";
  params.name = "conv";
  params.blobs = {weights};
  if (!bias.empty()) params.blobs.push_back(bias);
  params.set("bias_term", !bias.empty());
  params.set("num_output", weights.size[0]);
  params.set("kernel_size", cv::dnn::DictValue::arrayInt(&weights.size[2], 2));
  std::optional<DnnLayersScope> scope;
  if (layers.depthwise) scope.emplace(layers);
  cv::dnn::Net net;
  net.addLayerToPrev(params.name, params.type, params);
  net.setInput(input);
  const cv::Mat out = net.forward().clone();
  if (type) *type = net.getLayer(params.name)->type;
  return out;
}

TEST(DepthwiseStandIn, MatchesOpenCvsConvolutionForKernelsDilationsAndPaddings) {
  struct Case {
    int kh, kw, dh, dw, stride;
    std::vector<int> pads;  // top, left, bottom, right (OpenCV's layer wants them symmetric)
    bool bias, depthwise;
  };
  const std::vector<Case> cases = {
      {3, 3, 1, 1, 1, {1, 1, 1, 1}, false, true}, {1, 3, 1, 4, 1, {0, 4, 0, 4}, true, true},
      {3, 1, 1, 1, 1, {1, 0, 1, 0}, false, true}, {3, 3, 1, 8, 1, {1, 8, 1, 8}, false, true},
      {2, 2, 1, 1, 1, {0, 0, 0, 0}, true, true},  {1, 5, 2, 3, 1, {0, 0, 0, 0}, false, true},
      {3, 3, 2, 2, 1, {2, 1, 2, 1}, true, true},  {3, 3, 1, 1, 2, {1, 1, 1, 1}, false, true},
      {3, 3, 1, 1, 1, {1, 1, 1, 1}, true, false}};  // the last two stay OpenCV's
  cv::RNG rng(7);
  for (const Case& c : cases)
    for (int width : {1, 5, 16, 37}) {
      const int channels = 6, groups = c.depthwise ? channels : 1;
      cv::Mat input({2, channels, 9, width}, CV_32F),
          weights({channels, channels / groups, c.kh, c.kw}, CV_32F);
      rng.fill(input, cv::RNG::UNIFORM, -2, 2);
      rng.fill(weights, cv::RNG::UNIFORM, -1, 1);
      if (c.kh == 3 && c.kw == 3 && c.dw == 8) weights.setTo(0);  // zero taps are skipped
      cv::Mat bias;
      if (c.bias) {
        bias.create(1, channels, CV_32F);
        rng.fill(bias, cv::RNG::UNIFORM, -1, 1);
      }
      cv::dnn::LayerParams params;
      params.set("group", groups);
      const int stride[] = {c.stride, c.stride}, dilation[] = {c.dh, c.dw};
      params.set("stride", cv::dnn::DictValue::arrayInt(stride, 2));
      params.set("dilation", cv::dnn::DictValue::arrayInt(dilation, 2));
      const int pads[] = {c.pads[0], c.pads[1], c.pads[2], c.pads[3]};
      params.set("pad", cv::dnn::DictValue::arrayInt(pads, 4));
      if (width + c.pads[1] + c.pads[3] < c.dw * (c.kw - 1) + 1) continue;  // no output column
      const cv::Mat expected = convolve(input, weights, bias, params, DnnLayers::opencv());
      std::string type;
      DnnLayers no_dense_stand_in;  // the last case is test_product_layers' dense 3x3 one
      no_dense_stand_in.dense_3x3 = false;
      const cv::Mat got = convolve(input, weights, bias, params, no_dense_stand_in, &type);
      EXPECT_EQ(type, c.depthwise && c.stride == 1 ? "KeyfleetDepthwise" : "Convolution");
      ASSERT_EQ(cv::dnn::shape(got), cv::dnn::shape(expected)) << "width " << width;
      EXPECT_LT(cv::norm(got, expected, cv::NORM_INF), 1e-5)
          << c.kh << "x" << c.kw << " dilation " << c.dh << "," << c.dw << " width " << width;
    }
}

// --- DnnTextSegmenter --------------------------------------------------------------------------

TEST(DnnTextSegmenter, LoadsTheFixtureWithItsDescription) {
  DnnTextSegmenter segmenter(fixture("edge_text_segmenter.onnx"), 1);
  const SegmenterInfo& info = segmenter.info();
  EXPECT_EQ(info.input_size, cv::Size(256, 128));
  EXPECT_EQ(info.classes, (std::vector<std::string>{"background", "text"}));
  EXPECT_EQ(info.target_classes, (std::vector<int>{1}));
}

TEST(DnnTextSegmenter, BatchOfThreeFramesGivesThreeBinaryMasksAtTheInputSize) {
  DnnTextSegmenter segmenter(fixture("edge_text_segmenter.onnx"), 1);
  const std::vector<cv::Mat> frames = {make_text_image(640, 480), test::make_smooth_image(320, 240),
                                       test::make_noise_image(200, 150, 4)};
  const auto masks = segmenter.segment(frames);
  ASSERT_EQ(masks.size(), 3u);
  for (std::size_t i = 0; i < masks.size(); ++i) {
    EXPECT_EQ(masks[i].type(), CV_8UC1) << "mask " << i;
    EXPECT_EQ(masks[i].size(), cv::Size(256, 128)) << "mask " << i;
    const int text = cv::countNonZero(masks[i]);
    EXPECT_EQ(cv::countNonZero(masks[i] == 255), text) << "mask " << i << " is not 0/255";
  }
  EXPECT_GT(cv::countNonZero(masks[0]), 0) << "no text found on a sign";
  EXPECT_TRUE(segmenter.segment({}).empty());
}

TEST(DnnTextSegmenter, HighContrastTextGivesMoreMaskPixelsThanFlatGrey) {
  DnnTextSegmenter segmenter(fixture("edge_text_segmenter.onnx"), 1);
  const auto masks = segmenter.segment(
      {make_text_image(512, 256), cv::Mat(256, 512, CV_8UC3, cv::Scalar::all(128))});
  ASSERT_EQ(masks.size(), 2u);
  const int text = cv::countNonZero(masks[0]), flat = cv::countNonZero(masks[1]);
  EXPECT_GT(text, flat);
  EXPECT_GT(text, 100);
  EXPECT_EQ(flat, 0);
}

TEST(DnnTextSegmenter, MissingModelFileIsAStartupErrorNamingIt) {
  test::TempDir dir;
  fs::copy_file(fixture("edge_text_segmenter.json"), dir.file("absent.json"));
  const std::string model = dir.file("absent.onnx");
  const std::string message = startup_error_of(model);
  ASSERT_FALSE(message.empty()) << "expected StartupError";
  EXPECT_NE(message.find(model), std::string::npos) << message;
}

TEST(DnnTextSegmenter, TruncatedModelIsAStartupErrorNamingIt) {
  test::TempDir dir;
  const auto bytes = read_bytes(fixture("edge_text_segmenter.onnx"));
  ASSERT_GT(bytes.size(), 100u);
  const std::string model = dir.file("truncated.onnx");
  write_bytes(model, bytes.data(), bytes.size() / 2);
  fs::copy_file(fixture("edge_text_segmenter.json"), dir.file("truncated.json"));
  const std::string message = startup_error_of(model);
  ASSERT_FALSE(message.empty()) << "expected StartupError";
  EXPECT_NE(message.find(model), std::string::npos) << message;
}

TEST(DnnTextSegmenter, MissingDescriptionIsAStartupErrorNamingIt) {
  test::TempDir dir;
  const std::string model = dir.file("bare.onnx");
  fs::copy_file(fixture("edge_text_segmenter.onnx"), model);
  const std::string message = startup_error_of(model);
  ASSERT_FALSE(message.empty()) << "expected StartupError";
  EXPECT_NE(message.find(dir.file("bare.json")), std::string::npos) << message;
}

TEST(DnnTextSegmenter, BrokenDescriptionIsAStartupErrorNamingIt) {
  test::TempDir dir;
  const std::string model = dir.file("broken.onnx");
  fs::copy_file(fixture("edge_text_segmenter.onnx"), model);
  std::ofstream(dir.file("broken.json")) << "{\"format\": \"keyfleet-segmenter\", \"input_width\"";
  const std::string message = startup_error_of(model);
  ASSERT_FALSE(message.empty()) << "expected StartupError";
  EXPECT_NE(message.find(dir.file("broken.json")), std::string::npos) << message;
}

TEST(DnnTextSegmenter, ModelWithTheWrongInputShapeIsAStartupErrorNamingIt) {
  const std::string model = fixture("fixed_input_segmenter.onnx");
  const std::string message = startup_error_of(model);
  ASSERT_FALSE(message.empty()) << "expected StartupError";
  EXPECT_NE(message.find(model), std::string::npos) << message;
}

// --- semantic_score ----------------------------------------------------------------------------

TEST(SemanticScore, CentredTextScoresHigherThanTheSameTextAtTheBorder) {
  const cv::Size size(256, 128);
  const cv::Size blob(60, 20);
  cv::Mat centred = cv::Mat::zeros(size, CV_8U), at_left = centred.clone(),
          at_bottom = centred.clone();
  centred(cv::Rect({(size.width - blob.width) / 2, (size.height - blob.height) / 2}, blob))
      .setTo(255);
  at_left(cv::Rect({0, (size.height - blob.height) / 2}, blob)).setTo(255);
  at_bottom(cv::Rect({(size.width - blob.width) / 2, size.height - blob.height}, blob)).setTo(255);
  ASSERT_EQ(cv::countNonZero(centred), cv::countNonZero(at_left));
  const double border = 0.1;
  const double centre_score = semantic_score(centred, border);
  EXPECT_DOUBLE_EQ(centre_score, double(blob.area())) << "no text in the border band";
  EXPECT_GT(centre_score, semantic_score(at_left, border));
  EXPECT_GT(centre_score, semantic_score(at_bottom, border));
  EXPECT_GT(semantic_score(at_left, border), 0.0);
}

TEST(SemanticScore, NoTextScoresZero) {
  EXPECT_EQ(semantic_score(cv::Mat::zeros(128, 256, CV_8U), 0.1), 0.0);
  EXPECT_EQ(semantic_score(cv::Mat::zeros(32, 64, CV_8U), 0.0), 0.0);
}

TEST(SemanticScore, MoreCentredTextScoresHigher) {
  cv::Mat small = cv::Mat::zeros(128, 256, CV_8U), large = small.clone();
  small(cv::Rect(100, 50, 30, 10)).setTo(255);
  large(cv::Rect(80, 45, 90, 30)).setTo(255);
  EXPECT_GT(semantic_score(large, 0.1), semantic_score(small, 0.1));
}

}  // namespace
}  // namespace keyfleet::vision
