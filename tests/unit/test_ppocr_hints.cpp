// PpocrReader with the robot's text regions (ppocr_region_hints.cpp): the packing of padded
// hints into detector mosaics and the way back on hand-made cases; with the converted models,
// the modes on a keyframe whose hint is right, wrong, or a lie.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <optional>

#include "keyfleet/common/error.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "readers.hpp"

namespace keyfleet::station {
namespace {

using ppocr::MosaicPlacement;

TEST(PpocrHintMosaic, PaddedHintsArePackedInRowsTallestFirstAndOverlapsUnited) {
  // Padding 0.5 x height a side: 20-px-tall hints grow by 10 px (clipped at the image).
  const auto mosaics =
      ppocr::pack_hints({{100, 100, 60, 20}, {300, 50, 40, 40}, {105, 105, 30, 10}, {0, 0, 10, 10}},
                        {640, 480}, 0.5, {200, 200}, 8, 3);
  ASSERT_EQ(mosaics.size(), 1u);
  ASSERT_EQ(mosaics[0].size(), 3u);
  EXPECT_EQ(mosaics[0][0].source, cv::Rect(280, 30, 80, 80));  // the tallest first
  EXPECT_EQ(mosaics[0][0].at, cv::Point(0, 0));
  EXPECT_EQ(mosaics[0][1].source, cv::Rect(90, 90, 80, 40));  // two overlapping hints, united
  EXPECT_EQ(mosaics[0][1].at, cv::Point(88, 0));
  EXPECT_EQ(mosaics[0][2].source, cv::Rect(0, 0, 15, 15));  // clipped at the corner
  EXPECT_EQ(mosaics[0][2].at, cv::Point(176, 0));
}

TEST(PpocrHintMosaic, TooManyOrTooLargeGivesNothingAndOutsideHintsAreIgnored) {
  std::vector<cv::Rect> many;
  // Padded to 50 x 40 apart from each other: 3 a row, 4 rows a mosaic.
  for (int i = 0; i < 40; ++i) many.push_back({(i % 8) * 80 + 10, (i / 8) * 90 + 10, 30, 20});
  EXPECT_EQ(ppocr::pack_hints(many, {640, 480}, 0.5, {200, 200}, 8, 50).size(), 4u);
  EXPECT_TRUE(ppocr::pack_hints(many, {640, 480}, 0.5, {200, 200}, 8, 2).empty());
  EXPECT_TRUE(ppocr::pack_hints({{0, 0, 600, 40}}, {640, 480}, 0.5, {200, 200}, 8, 2).empty());
  const auto outside = ppocr::pack_hints({{-500, -500, 10, 10}, {9000, 10, 5, 5}}, {640, 480}, 0.5,
                                         {200, 200}, 8, 2);
  EXPECT_TRUE(outside.empty() || outside[0].empty());
}

TEST(PpocrHintMosaic, LinesComeBackToTheImageOrAreDroppedInTheGaps) {
  const std::vector<MosaicPlacement> placed = {{{300, 200, 100, 40}, {0, 0}},
                                               {{10, 10, 50, 30}, {108, 0}}};
  const TextQuad first = {cv::Point2f(5, 5), {95, 5}, {95, 35}, {5, 35}};
  const auto back = ppocr::quad_in_image(first, placed);
  ASSERT_TRUE(back);
  EXPECT_EQ((*back)[0], cv::Point2f(305, 205));
  EXPECT_EQ((*back)[2], cv::Point2f(395, 235));
  const TextQuad second = {cv::Point2f(110, 2), {170, 2}, {170, 28}, {110, 28}};  // spills over
  const auto clamped = ppocr::quad_in_image(second, placed);
  ASSERT_TRUE(clamped);
  EXPECT_EQ((*clamped)[1], cv::Point2f(59, 12));
  const TextQuad gap = {cv::Point2f(101, 0), {107, 0}, {107, 10}, {101, 10}};
  EXPECT_FALSE(ppocr::quad_in_image(gap, placed));
}

// ---------------------------------------------------------------- with the converted models

bool have_models() {
  try {
    vision::locate_model("ppocr/ppocr_det_640x480.onnx", "ppocr detector");
    vision::locate_model("ppocr/ppocr_det_1280x736.onnx", "ppocr detector");
    return true;
  } catch (const StartupError&) {
    return false;
  }
}

#define KEYFLEET_REQUIRE_PPOCR_MODELS()                                                         \
  if (!have_models())                                                                           \
  GTEST_SKIP() << "the converted ppocr models are not in <build>/share/keyfleet/models/ppocr; " \
                  "run scripts/fetch_ppocr.sh to download and convert them"

TextReadingConfig hinted(const std::string& mode) {
  TextReadingConfig config;
  config.engine = "ppocr";
  config.ppocr.detector_size = "1280x736";
  config.ppocr.region_hints = mode;
  return config;
}

cv::Mat keyframe_with_word() {
  cv::Mat keyframe(480, 640, CV_8UC3, cv::Scalar(200, 210, 220));
  cv::putText(keyframe, "STATION", {120, 260}, cv::FONT_HERSHEY_DUPLEX, 1.5, cv::Scalar(30, 30, 30),
              3, cv::LINE_AA);
  return keyframe;
}

std::vector<std::string> texts(const std::vector<ReadWord>& words) {
  std::vector<std::string> out;
  for (const auto& w : words) out.push_back(w.text);
  return out;
}

TEST(PpocrHintsWithModels, OnlyReadsWhereTheHintPointsFirstFallsBackOnTheWholeImage) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  const cv::Mat image = keyframe_with_word();
  const cv::Rect on_word(115, 225, 260, 45), elsewhere(400, 50, 100, 30);
  const auto only = make_text_reader(hinted("only"));
  const auto first = make_text_reader(hinted("first"));
  const auto off = make_text_reader(hinted("off"));
  const std::vector<std::string> station = {"STATION"};
  EXPECT_EQ(texts(off->read_with_hints(image, {on_word})), station);
  const auto read = only->read_with_hints(image, {on_word});
  ASSERT_EQ(texts(read), station);
  EXPECT_NEAR(read[0].box.x, 120, 20);  // in the image's pixels, not the mosaic's
  EXPECT_NEAR(read[0].box.y + read[0].box.height, 260, 20);
  EXPECT_TRUE(only->read_with_hints(image, {elsewhere}).empty());
  EXPECT_EQ(texts(first->read_with_hints(image, {elsewhere})), station);
  EXPECT_EQ(texts(only->read_with_hints(image, {})), station);  // no hints: the whole image
}

TEST(PpocrHintsWithModels, LyingHintsGiveNoCrash) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  const auto reader = make_text_reader(hinted("only"));
  const cv::Mat image = keyframe_with_word();
  for (const std::vector<cv::Rect>& lies : {std::vector<cv::Rect>{{-100, -100, 50, 50}},
                                            {{0, 0, 100000, 100000}},
                                            {{630, 470, 500, 500}},
                                            {{10, 10, 0, 0}},
                                            std::vector<cv::Rect>(500, {1, 1, 30, 10})}) {
    EXPECT_NO_THROW(reader->read_with_hints(image, lies));
  }
  EXPECT_TRUE(reader->read_with_hints(cv::Mat(), {{1, 1, 5, 5}}).empty());
}

TEST(PpocrHintsStartup, UnknownModeIsRefused) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  EXPECT_THROW(make_text_reader(hinted("sometimes")), StartupError);
}

// A hint detector size the fetch does not convert is refused as a setting, naming it, not taken
// for a missing install (which the station's fallback engine would stand in for).
TEST(PpocrHintsStartup, AnUnconvertedSizeIsRefusedAsTheSetting) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  auto config = hinted("only");
  config.ppocr.region_hint_detector_size = "416x320";
  try {
    make_text_reader(config);
    ADD_FAILURE() << "an unconverted hint detector size was accepted";
  } catch (const EngineModelsMissing& e) {
    ADD_FAILURE() << "taken for a missing install: " << e.what();
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("region_hint_detector_size"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("ppocr_det_416x320.onnx"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace keyfleet::station
