// The agent's default semantic model, PP-OCRv4's text detector tuned to 256x192 and described as a
// text segmenter (models/ppocr_tuned/, which the build copies beside the programs; made by
// scripts/tune_detector.sh): it loads from the default config,
// marks a drawn word where it was drawn, finds the text of generated views and of unseen real
// photos above stated floors (in float products too, where the CPU would use bfloat16 ones). And
// the segmenter description's probability-output fields: what they accept and what they refuse.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "generated_views.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/segmenter_eval.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/semantic_config.hpp"
#include "keyfleet/vision/text_segmenter.hpp"
#include "test_support.hpp"

namespace keyfleet::vision {
namespace {

using namespace ::keyfleet::eval;

namespace fs = std::filesystem;

#define KEYFLEET_REQUIRE_DEFAULT_SEMANTIC_MODEL()                                  \
  try {                                                                            \
    locate_model(SemanticConfig{}.model, "segmenter model");                       \
  } catch (const StartupError& e) {                                                \
    GTEST_SKIP() << e.what() << " (the build copies it from models/ppocr_tuned/)"; \
  }

TEST(AgentSemanticModel, TheDefaultIsPpocrsDetectorDescribedAsAProbabilitySegmenter) {
  KEYFLEET_REQUIRE_DEFAULT_SEMANTIC_MODEL();
  const auto segmenter = make_text_segmenter(SemanticConfig{});
  const SegmenterInfo& info = segmenter->info();
  EXPECT_EQ(info.input_size, cv::Size(256, 192));
  EXPECT_EQ(info.output, SegmenterInfo::Output::kTextProbability);
  EXPECT_NEAR(info.std_bgr[0], 0.229, 1e-6);
  EXPECT_NEAR(info.boxes.unclip_ratio, 1.5f, 1e-6);
  EXPECT_GT(info.gflops_512x256, 1.0);
  EXPECT_EQ(info.max_batch, 1);
  // Blank frames hold no text; more frames than a pass takes are segmented one by one.
  const cv::Mat blank(480, 640, CV_8UC3, cv::Scalar::all(90));
  const auto masks = segmenter->segment({blank, blank, blank});
  ASSERT_EQ(masks.size(), 3u);
  for (const auto& mask : masks) EXPECT_EQ(cv::countNonZero(mask), 0);
}

TEST(AgentSemanticModel, MarksADrawnWordWhereItWasDrawn) {
  KEYFLEET_REQUIRE_DEFAULT_SEMANTIC_MODEL();
  const auto segmenter = make_text_segmenter(SemanticConfig{});
  cv::Mat frame(480, 640, CV_8UC3, cv::Scalar(200, 205, 210));
  const cv::Rect word(160, 300, 320, 70);  // where "HOTEL" goes, in frame pixels
  cv::putText(frame, "HOTEL", {word.x + 10, word.y + 60}, cv::FONT_HERSHEY_DUPLEX, 2.6,
              cv::Scalar(20, 20, 20), 6);
  const cv::Mat mask = segmenter->segment({frame}).at(0);
  ASSERT_EQ(mask.size(), segmenter->info().input_size);
  const cv::Rect in_mask(word.x * mask.cols / 640, word.y * mask.rows / 480,
                         word.width * mask.cols / 640, word.height * mask.rows / 480);
  const int inside = cv::countNonZero(mask(in_mask));
  const int all = cv::countNonZero(mask);
  EXPECT_GT(inside, in_mask.area() / 2) << "the word's box is not marked";
  EXPECT_GT(inside, all * 8 / 10) << "text marked away from the word";
}

// Floors about 0.1 below the model's own figures on these views (recall 0.772, precision 0.410,
// IoU 0.366, rank 0.85 when recorded; the untuned detector at 288x224 0.603 / 0.570 / 0.414,
// 0.75; at 320x256 0.674 / 0.636 / 0.486, 0.75): a regression below them fails. The tuned model
// finds more of the signs and also marks some windows (docs/results/2026-11-27-tuned-detector.md).
// MiniNet there: 0.63 / 0.32 / 0.27, rank 0.68.
// The default config (float products with the wide 1x1 layers in int8), all in float (OpenCV's
// logits to float rounding), and in bfloat16 where the CPU has AVX512-BF16.
std::vector<SemanticConfig> both_precisions() {
  std::vector<SemanticConfig> configs = {SemanticConfig{}};
  configs.push_back(SemanticConfig{});
  configs.back().int8 = configs.back().bfloat16 = false;
  if (bfloat16_products_supported()) {
    configs.push_back(SemanticConfig{});
    configs.back().bfloat16 = true;
  }
  return configs;
}

std::string precision_name(const SemanticConfig& config) {
  return std::string(config.bfloat16 ? "bfloat16" : "float") + " products" +
         (config.int8 ? ", int8 1x1" : "");
}

TEST(AgentSemanticModel, FindsTextPixelsOfGeneratedViewsAboveStatedFloors) {
  KEYFLEET_REQUIRE_DEFAULT_SEMANTIC_MODEL();
  for (const SemanticConfig& config : both_precisions()) {
    auto segmenter = make_text_segmenter(config);
    const SegmentationScores s = test::score_on_generated_views(*segmenter);
    SCOPED_TRACE(precision_name(config));
    EXPECT_EQ(s.images, test::kGeneratedViews);
    EXPECT_GT(s.recall, 0.67) << "precision " << s.precision << ", IoU " << s.iou;
    EXPECT_GT(s.precision, 0.31) << "recall " << s.recall << ", IoU " << s.iou;
    EXPECT_GT(s.iou, 0.27) << "recall " << s.recall << ", precision " << s.precision;
    EXPECT_GT(s.frame_rank_correlation, 0.6);
  }
}

// Real photos no model here was trained or tuned on (ICDAR 2015 test_clean, the first 20), as
// Table III scores them, at the model's 256x192. Floors about 0.05 below its figures when
// recorded (recall 0.315, precision 0.565, IoU 0.253, rank 0.49; the untuned detector at 288x224
// 0.281 / 0.618 / 0.240, 0.39; at 320x256 0.276 / 0.697 / 0.246, 0.49); the shipped MiniNet
// there: 0.084 / 0.102 / 0.048.
TEST(AgentSemanticModel, FindsTextPixelsOfUnseenRealPhotosAboveStatedFloors) {
  KEYFLEET_REQUIRE_DEFAULT_SEMANTIC_MODEL();
  KEYFLEET_REQUIRE_DATA("icdar2015/test_clean");
  for (const SemanticConfig& config : both_precisions()) {
    auto segmenter = make_text_segmenter(config);
    const SegmentationScores s = evaluate_on_icdar(*segmenter, (data_path / "images").string(),
                                                   (data_path / "gt").string(), 20);
    SCOPED_TRACE(precision_name(config));
    EXPECT_EQ(s.images, 20u);
    EXPECT_GT(s.recall, 0.26) << "precision " << s.precision << ", IoU " << s.iou;
    EXPECT_GT(s.precision, 0.51) << "recall " << s.recall << ", IoU " << s.iou;
    EXPECT_GT(s.iou, 0.20) << "recall " << s.recall << ", precision " << s.precision;
    // Frames rank as their text does (20 photos: a wide interval, so a low floor).
    EXPECT_GT(s.frame_rank_correlation, 0.2);
  }
}

// ------------------------------------------------------------ the description's fields

class SegmenterDescription : public ::testing::Test {
 protected:
  std::string write(const std::string& extra) {
    std::ofstream(dir_.path() / "net.json")
        << R"({"format": "keyfleet-segmenter", "version": 1, "input_width": 320,
               "input_height": 256, "size_multiple": 32, "scale": 0.00392156862745098,
               "mean_bgr": [123.675, 116.28, 103.53], "classes": ["text"],
               "target_classes": ["text"])"
        << extra << "}";
    return (dir_.path() / "net.onnx").string();
  }
  test::TempDir dir_;
};

TEST_F(SegmenterDescription, ReadsStdAndTheDbSettingsOfAProbabilityOutput) {
  const SegmenterInfo info =
      read_segmenter_info(write(R"(, "std_bgr": [0.229, 0.224, 0.225], "output": "text_probability",
               "db": {"binary_threshold": 0.2, "box_threshold": 0.5, "unclip_ratio": 2.0})"));
  EXPECT_EQ(info.output, SegmenterInfo::Output::kTextProbability);
  EXPECT_NEAR(info.std_bgr[2], 0.225, 1e-9);
  EXPECT_FLOAT_EQ(info.boxes.binary_threshold, 0.2f);
  EXPECT_FLOAT_EQ(info.boxes.box_threshold, 0.5f);
  EXPECT_FLOAT_EQ(info.boxes.unclip_ratio, 2.0f);
  EXPECT_FLOAT_EQ(info.boxes.min_size, DbParams{}.min_size);  // not given: DB's default
  // Without the new fields: class logits and no division.
  const SegmenterInfo plain = read_segmenter_info(write(""));
  EXPECT_EQ(plain.output, SegmenterInfo::Output::kClassLogits);
  EXPECT_EQ(plain.std_bgr, cv::Scalar(1, 1, 1));
}

TEST_F(SegmenterDescription, RefusesBadValuesNamingTheFile) {
  for (const std::string extra :
       {R"(, "std_bgr": [0.229, 0, 0.225])", R"(, "max_batch": -1)", R"(, "max_batch": 1e30)",
        R"(, "max_batch": 2.5)", R"(, "max_batch": "4")", R"(, "std_bgr": [0.229, -1, 0.225])",
        R"(, "std_bgr": [0.229, 1e999, 0.225])", R"(, "output": "boxes")",
        R"(, "output": "text_probability", "db": {"binary_threshold": 1.5})",
        R"(, "output": "text_probability", "db": {"box_threshold": -0.1})",
        R"(, "output": "text_probability", "db": {"unclip_ratio": -1})",
        R"(, "output": "text_probability", "classes": ["background", "text"])"}) {
    try {
      read_segmenter_info(write(extra));
      ADD_FAILURE() << "accepted " << extra;
    } catch (const StartupError& e) {
      EXPECT_NE(std::string(e.what()).find("net.json"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace keyfleet::vision
