// The ppocr text engine (PP-OCRv4 in OpenCV DNN): CTC decoding on hand-made inputs; with the
// converted models (scripts/fetch_ppocr.sh) the reader on hostile images, missing files and real
// word crops.
#include <gtest/gtest.h>

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <tuple>

#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/text_dataset_eval.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "ppocr_detector.hpp"
#include "ppocr_recognizer.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

namespace fs = std::filesystem;

// The converted models' folder, found the way the station finds it; nothing when absent.
std::optional<fs::path> ppocr_models() {
  try {
    return fs::path(vision::locate_model("ppocr/ppocr_det_640x480.onnx", "ppocr detector"))
        .parent_path();
  } catch (const StartupError&) {
    return std::nullopt;
  }
}

#define KEYFLEET_REQUIRE_PPOCR_MODELS()                                                         \
  const auto models = ppocr_models();                                                           \
  if (!models)                                                                                  \
  GTEST_SKIP() << "the converted ppocr models are not in <build>/share/keyfleet/models/ppocr; " \
                  "run scripts/fetch_ppocr.sh to download and convert them"

TextReadingConfig ppocr_config(bool int8 = true) {
  TextReadingConfig config;
  config.engine = "ppocr";
  config.ppocr.int8 = int8;
  return config;
}

// ---------------------------------------------------------------- CTC decoding

// One row per time step: probability `p` on class `c`, the rest spread over the others.
cv::Mat steps(const std::vector<std::pair<int, float>>& best, int classes) {
  cv::Mat probs(int(best.size()), classes, CV_32F);
  for (int t = 0; t < probs.rows; ++t) {
    probs.row(t).setTo((1 - best[std::size_t(t)].second) / float(classes - 1));
    probs.at<float>(t, best[std::size_t(t)].first) = best[std::size_t(t)].second;
  }
  return probs;
}

TEST(PpocrCtcDecode, CollapsesRepeatsBlanksSeparateSpacesSplitWords) {
  const std::vector<std::string> classes = {"", "a", "b", "c", " "};
  const int blank = 0, a = 1, b = 2, c = 3, space = 4;
  const cv::Mat probs = steps({{a, 0.9f},
                               {a, 0.8f},  // repeat: still the first "a"
                               {blank, 0.9f},
                               {a, 0.7f},  // after a blank: a second "a"
                               {b, 0.6f},
                               {space, 0.9f},
                               {c, 0.95f},
                               {c, 0.5f}},
                              int(classes.size()));
  // 8 steps of a 64-column input, all of it content; the line is 64 x 10 px.
  const TextQuad line = {cv::Point2f(0, 0), cv::Point2f(64, 0), cv::Point2f(64, 10),
                         cv::Point2f(0, 10)};
  const auto decoded = ppocr::ctc_decode(probs, classes, 64, 64, line, false);
  ASSERT_EQ(decoded.words.size(), 2u);
  EXPECT_EQ(decoded.words[0].text, "aab");
  EXPECT_NEAR(decoded.words[0].confidence, (0.9 + 0.7 + 0.6) / 3, 1e-5);
  EXPECT_EQ(decoded.words[1].text, "c");
  EXPECT_NEAR(decoded.words[1].confidence, 0.95, 1e-5);
  // Word boxes follow the time steps: "aab" steps 0..4 -> x 0..40, "c" steps 6..7 -> 48..64.
  EXPECT_NEAR(decoded.words[0].quad[0].x, 0, 1e-4);
  EXPECT_NEAR(decoded.words[0].quad[1].x, 40, 1e-4);
  EXPECT_NEAR(decoded.words[1].quad[0].x, 48, 1e-4);
  EXPECT_NEAR(decoded.words[1].quad[2].x, 64, 1e-4);
  EXPECT_NEAR(decoded.words[1].quad[2].y, 10, 1e-4);
}

TEST(PpocrCtcDecode, BlanksOnlyOrMismatchedClassesGiveNoWords) {
  const std::vector<std::string> classes = {"", "a", " "};
  const TextQuad line = {cv::Point2f(0, 0), cv::Point2f(32, 0), cv::Point2f(32, 8),
                         cv::Point2f(0, 8)};
  EXPECT_TRUE(ppocr::ctc_decode(steps({{0, 0.9f}, {2, 0.9f}, {0, 0.9f}, {2, 0.9f}}, 3), classes, 32,
                                32, line, false)
                  .words.empty());
  EXPECT_TRUE(ppocr::ctc_decode(steps({{1, 0.9f}}, 4), classes, 32, 32, line, false).words.empty());
  EXPECT_TRUE(ppocr::ctc_decode(cv::Mat(), classes, 32, 32, line, false).words.empty());
}

TEST(PpocrCtcDecode, SplitsWordsWhereASpaceIsLikelyThoughNotBest) {
  const std::vector<std::string> classes = {"", "a", "b", " "};
  const int blank = 0, a = 1, b = 2, space = 3;
  // "a", a blank step where the space has 0.3 (the blank wins), then "b".
  cv::Mat probs = steps({{a, 0.9f}, {blank, 0.6f}, {b, 0.9f}}, int(classes.size()));
  probs.at<float>(1, space) = 0.3f;
  const TextQuad line = {cv::Point2f(0, 0), cv::Point2f(24, 0), cv::Point2f(24, 8),
                         cv::Point2f(0, 8)};
  ppocr::CtcOptions options;
  options.space_probability = 0.2f;
  const auto split = ppocr::ctc_decode(probs, classes, 24, 24, line, false, options);
  ASSERT_EQ(split.words.size(), 2u);
  EXPECT_EQ(split.words[0].text, "a");
  EXPECT_EQ(split.words[1].text, "b");
  options.space_probability = 0.5f;  // not likely enough: one word
  const auto joined = ppocr::ctc_decode(probs, classes, 24, 24, line, false, options);
  ASSERT_EQ(joined.words.size(), 1u);
  EXPECT_EQ(joined.words[0].text, "ab");
}

TEST(PpocrCtcDecode, LatinOnlyReadsTheBestLatinClass) {
  const std::vector<std::string> classes = {"", "\xE4\xB8\xAA" /* U+4E2A */, "T", "\xC3\xA9", " "};
  const auto latin = ppocr::latin_classes(classes);
  EXPECT_EQ(latin, (std::vector<bool>{true, false, true, true, true}));
  // The Chinese class wins the step; the Latin "T" is second.
  cv::Mat probs = steps({{1, 0.6f}, {3, 0.9f}}, int(classes.size()));
  probs.at<float>(0, 2) = 0.3f;
  const TextQuad line = {cv::Point2f(0, 0), cv::Point2f(16, 0), cv::Point2f(16, 8),
                         cv::Point2f(0, 8)};
  EXPECT_EQ(ppocr::ctc_decode(probs, classes, 16, 16, line, false).words.at(0).text,
            "\xE4\xB8\xAA\xC3\xA9");
  ppocr::CtcOptions options;
  options.allowed = latin;
  EXPECT_EQ(ppocr::ctc_decode(probs, classes, 16, 16, line, false, options).words.at(0).text,
            "T\xC3\xA9");
}

TEST(PpocrCropQuad, RejectsDegenerateAndAbsurdQuads) {
  const cv::Mat image(100, 100, CV_8UC3, cv::Scalar(128, 128, 128));
  const float nan = std::nanf("");
  EXPECT_TRUE(ppocr::crop_quad(image, {cv::Point2f(0, 0), cv::Point2f(1, 0), cv::Point2f(1, 1),
                                       cv::Point2f(0, 1)})
                  .empty());
  EXPECT_TRUE(ppocr::crop_quad(image, {cv::Point2f(nan, 0), cv::Point2f(50, 0), cv::Point2f(50, 20),
                                       cv::Point2f(0, 20)})
                  .empty());
  EXPECT_TRUE(ppocr::crop_quad(image, {cv::Point2f(0, 0), cv::Point2f(1e6f, 0),
                                       cv::Point2f(1e6f, 20), cv::Point2f(0, 20)})
                  .empty());
  bool rotated = true;
  const cv::Mat crop = ppocr::crop_quad(
      image, {cv::Point2f(10, 10), cv::Point2f(60, 10), cv::Point2f(60, 30), cv::Point2f(10, 30)},
      &rotated);
  EXPECT_EQ(crop.size(), cv::Size(50, 20));
  EXPECT_FALSE(rotated);
  // Twice as tall as wide: vertical text, turned to run left to right.
  const cv::Mat tall = ppocr::crop_quad(
      image, {cv::Point2f(10, 10), cv::Point2f(30, 10), cv::Point2f(30, 60), cv::Point2f(10, 60)},
      &rotated);
  EXPECT_EQ(tall.size(), cv::Size(50, 20));
  EXPECT_TRUE(rotated);
}

// The detector's input in one pass is the blob OpenCV's convertTo, subtract, divide and
// blobFromImage made of the letterboxed image (padded with 0), to the bit; a reused blob of
// another size is remade and one of the same size repadded.
TEST(PpocrDetectorInput, OnePassGivesTheBlobOpenCvsStepsGave) {
  const auto reference = [](const cv::Mat& bgr, cv::Size input) {
    cv::Mat normalised;
    bgr.convertTo(normalised, CV_32FC3, 1.0 / 255.0);
    normalised -= cv::Scalar(0.485f, 0.456f, 0.406f);
    cv::divide(normalised, cv::Scalar(0.229f, 0.224f, 0.225f), normalised);
    cv::Mat padded(input, CV_32FC3, cv::Scalar::all(0));
    normalised.copyTo(padded(cv::Rect(cv::Point(0, 0), bgr.size())));
    return cv::dnn::blobFromImage(padded);
  };
  cv::Mat blob;
  for (const auto& [image, input] : {std::pair{cv::Size(640, 480), cv::Size(640, 480)},
                                     std::pair{cv::Size(600, 333), cv::Size(640, 480)},
                                     std::pair{cv::Size(320, 256), cv::Size(320, 256)},
                                     std::pair{cv::Size(250, 256), cv::Size(320, 256)}}) {
    cv::Mat bgr(image, CV_8UC3);
    cv::randu(bgr, 0, 256);
    ppocr::fill_input_planes(bgr, input, blob);
    const cv::Mat expected = reference(bgr, input);
    ASSERT_EQ(blob.total(), expected.total()) << image;
    EXPECT_EQ(cv::norm(blob, expected, cv::NORM_INF), 0.0) << image << " into " << input;
  }
}

// ---------------------------------------------------------------- start-up errors

TEST(PpocrReaderStartup, MissingModelFolderNamesTheFile) {
  auto config = ppocr_config();
  config.ppocr.models = "/nonexistent/ppocr";
  try {
    make_text_reader(config);
    FAIL() << "no StartupError";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/ppocr/ppocr_det_640x480.onnx"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("fetch_ppocr.sh"), std::string::npos) << e.what();
  }
}

TEST(PpocrReaderStartup, BadDetectorSizeOrThresholdIsRefused) {
  auto config = ppocr_config();
  config.ppocr.detector_size = "650x480";
  EXPECT_THROW(make_text_reader(config), StartupError);
  config.ppocr.detector_size = "640";
  EXPECT_THROW(make_text_reader(config), StartupError);
  config = ppocr_config();
  config.ppocr.models = "/nonexistent/ppocr";
  config.ppocr.box_threshold = 1.5;
  EXPECT_THROW(make_text_reader(config), StartupError);
}

// make_text_reader refuses `config` at start-up with a message naming `file`.
void expect_refusal_naming(const TextReadingConfig& config, const std::string& file) {
  try {
    make_text_reader(config);
    ADD_FAILURE() << "no StartupError; expected one naming " << file;
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
  }
}

TEST(PpocrReaderStartup, MissingRecogniserFileIsNamed) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  test::TempDir dir;
  for (const auto& entry : fs::directory_iterator(*models))
    if (entry.path().filename() != "ppocr_rec_latin_w320.onnx")
      fs::copy_file(entry.path(), dir.path() / entry.path().filename());
  auto config = ppocr_config();
  config.ppocr.models = dir.path().string();
  expect_refusal_naming(config, "ppocr_rec_latin_w320.onnx");
  // A file that is not a network is refused at start-up, naming it.
  { std::ofstream(dir.file("ppocr_rec_latin_w320.onnx")) << "not a model"; }
  expect_refusal_naming(config, "ppocr_rec_latin_w320.onnx");
  // Without Latin only, the whole list's files are read: this one is missing.
  config.ppocr.latin_only = false;
  fs::remove(dir.file("ppocr_rec_w160.onnx"));
  expect_refusal_naming(config, "ppocr_rec_w160.onnx");
}

// A keyframe detector that is missing, or whose .json gives an input larger than a keyframe's, is
// refused at start-up with the setting and the file named.
TEST(PpocrReaderStartup, BadKeyframeDetectorIsNamed) {
  auto config = ppocr_config();
  config.ppocr.keyframe_detector = "/nonexistent/ppocr_det_512x384_tuned.onnx";
  expect_refusal_naming(config, "/nonexistent/ppocr_det_512x384_tuned.onnx");
  expect_refusal_naming(config, "ppocr_keyframe_detector");
  test::TempDir dir;
  { std::ofstream(dir.file("big.onnx")) << "not read before its size is checked"; }
  {
    std::ofstream(dir.file("big.json"))
        << R"({"format": "keyfleet-segmenter", "input_width": 1280, "input_height": 736,
              "size_multiple": 32, "scale": 0.0039, "mean_bgr": [123.7, 116.3, 103.5],
              "output": "text_probability", "classes": ["text"], "target_classes": ["text"]})";
  }
  config.ppocr.keyframe_detector = dir.file("big.onnx");
  expect_refusal_naming(config, "within a keyframe's 640x480");
  // Only "auto" has a keyframe detector: with a fixed size (one file for every image) the
  // setting would be ignored, so it is refused.
  config.ppocr.detector_size = "1280x736";
  expect_refusal_naming(config, "under ppocr_detector_size auto, but the size is '1280x736'");
}

// ---------------------------------------------------------------- with the converted models

TEST(PpocrReaderWithModels, LoadsAndSurvivesHostileImages) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  const auto reader = make_text_reader(ppocr_config());
  EXPECT_EQ(reader->name(), "ppocr");
  EXPECT_TRUE(reader->read(cv::Mat()).empty());
  EXPECT_TRUE(reader->read(cv::Mat(1, 1, CV_8UC3, cv::Scalar(255, 255, 255))).empty());
  EXPECT_TRUE(reader->read(cv::Mat(8192, 8192, CV_8UC3, cv::Scalar(0, 0, 0))).empty());
  EXPECT_TRUE(reader->read(cv::Mat(480, 640, CV_8UC4, cv::Scalar(0, 0, 0, 255))).empty());
  EXPECT_TRUE(reader->read(cv::Mat(480, 640, CV_16UC3, cv::Scalar(0, 0, 0))).empty());
  EXPECT_TRUE(reader->read(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0))).empty());
  EXPECT_TRUE(reader->read(cv::Mat(2, 5000, CV_8UC1, cv::Scalar(0))).empty());
}

TEST(PpocrReaderWithModels, ReadsAPrintedWordInAKeyframe) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  cv::Mat keyframe(480, 640, CV_8UC3, cv::Scalar(200, 210, 220));
  cv::putText(keyframe, "STATION", {120, 260}, cv::FONT_HERSHEY_DUPLEX, 3.0, cv::Scalar(30, 30, 30),
              6, cv::LINE_AA);
  cv::Mat bgra;
  cv::cvtColor(keyframe, bgra, cv::COLOR_BGR2BGRA);
  for (const bool int8 : {true, false})
    for (const cv::Mat& image : {keyframe, bgra}) {
      SCOPED_TRACE(int8 ? "int8 1x1 convolutions" : "float");
      const auto words = make_text_reader(ppocr_config(int8))->read(image);
      ASSERT_EQ(words.size(), 1u);
      EXPECT_EQ(words[0].text, "STATION");
      EXPECT_GE(words[0].confidence, 0.7f);
      // The box holds the drawn text (x 120.., baseline 260, about 65 px tall).
      EXPECT_NEAR(words[0].box.x, 120, 25);
      EXPECT_NEAR(words[0].box.y + words[0].box.height, 260, 25);
    }
}

// ppocr_keyframe_detector takes the images that fit a keyframe, letterboxed into its smaller
// input (the word's box still in the keyframe's pixels); larger images keep the fetched 1280x736
// file, as without it. The test's keyframe detector is the fetched 320x256 segmenter conversion.
TEST(PpocrReaderWithModels, KeyframeDetectorReadsKeyframesOnly) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  cv::Mat keyframe(480, 640, CV_8UC3, cv::Scalar(200, 210, 220));
  cv::putText(keyframe, "STATION", {120, 260}, cv::FONT_HERSHEY_DUPLEX, 3.0, cv::Scalar(30, 30, 30),
              6, cv::LINE_AA);
  cv::Mat photo(720, 1280, CV_8UC3, cv::Scalar(200, 210, 220));
  cv::putText(photo, "HARBOUR", {300, 400}, cv::FONT_HERSHEY_DUPLEX, 2.0, cv::Scalar(30, 30, 30), 4,
              cv::LINE_AA);
  auto config = ppocr_config();
  const auto fetched = make_text_reader(config);
  config.ppocr.keyframe_detector = "ppocr/ppocr_det_320x256.onnx";
  const auto tuned = make_text_reader(config);
  const auto words = tuned->read(keyframe);
  ASSERT_EQ(words.size(), 1u);

  EXPECT_EQ(words[0].text, "STATION");
  // The line found at half the resolution: in the keyframe's pixels, within a few of the fetched
  // 640x480 file's box (measured 8 px apart at the left end), but not its box (that file is not
  // what read it) ...
  const auto before = fetched->read(keyframe);
  ASSERT_EQ(before.size(), 1u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(words[0].quad[i].x, before[0].quad[i].x, 12) << "corner " << i;
    EXPECT_NEAR(words[0].quad[i].y, before[0].quad[i].y, 12) << "corner " << i;
  }
  EXPECT_NE(words[0].quad, before[0].quad);
  // ... while a 1280x720 photo goes to the same 1280x736 file with or without it.
  const auto photo_words = tuned->read(photo), photo_before = fetched->read(photo);
  ASSERT_EQ(photo_words.size(), 1u);
  EXPECT_EQ(photo_words[0].text, "HARBOUR");
  ASSERT_EQ(photo_before.size(), 1u);
  EXPECT_EQ(photo_words[0].quad, photo_before[0].quad);
}

// A detector built on first use (the 1280x736 file under "auto") is only parsed and its map's
// shape checked at start: a corrupt file is refused then, naming it; the first image builds it
// and it finds what a detector built at once finds.
TEST(PpocrReaderWithModels, DetectorBuiltOnFirstUseFindsWhatOneBuiltAtOnceFinds) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  using Build = PpocrDetector::Build;
  const vision::DnnLayers layers = vision::DnnLayers::in_float();
  test::TempDir dir;
  { std::ofstream(dir.file("corrupt.onnx")) << "not a network"; }
  try {
    PpocrDetector(dir.file("corrupt.onnx"), {1280, 736}, DbParams{}, layers, Build::kOnFirstUse);
    ADD_FAILURE() << "a corrupt file was accepted";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt.onnx"), std::string::npos) << e.what();
  }
  const std::string file = (*models / "ppocr_det_1280x736.onnx").string();
  PpocrDetector later(file, {1280, 736}, DbParams{}, layers, Build::kOnFirstUse);
  EXPECT_FALSE(later.built());
  PpocrDetector now(file, {1280, 736}, DbParams{}, layers, Build::kNow);
  EXPECT_TRUE(now.built());
  cv::Mat photo(720, 1280, CV_8UC3, cv::Scalar(200, 210, 220));
  cv::putText(photo, "HARBOUR", {300, 400}, cv::FONT_HERSHEY_DUPLEX, 2.0, cv::Scalar(30, 30, 30), 4,
              cv::LINE_AA);
  EXPECT_TRUE(later.detect(cv::Mat()).empty());
  EXPECT_FALSE(later.built());  // an unusable image does not build it
  const auto found = later.detect(photo), expected = now.detect(photo);
  EXPECT_TRUE(later.built());
  ASSERT_EQ(expected.size(), 1u);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].quad, expected[0].quad);
}

// In float, keyfleet's stand-in layers give OpenCV's own outputs of both networks to float rounding
// on a random input (the recogniser chains activations after its 1x1 convolutions: a stand-in
// that dropped one was off by 0.45). The station's default, the wide 1x1 convolutions in int8, is
// checked on what it reads (above and below).
TEST(PpocrReaderWithModels, StandInLayersGiveOpenCvsOutputs) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  // The detectors at both sizes: at 640x480 four of their layer pairs run fused a band of rows
  // at a time (the first layer's, two 1x1 layers' and the DB head's), at 1280x736 nine; at
  // every size, the agent's included, the FPN's levels upsampled by 8 and 4 reach the DB head's
  // 3x3 layer at their own size, and three of its four RSE layers' 1x1 convolutions are scaled
  // and summed by the sums after them (the top level's output has two readers).
  for (const auto& [file, height, width, fused, handed, excited] :
       {std::tuple{"ppocr_det_640x480.onnx", 480, 640, 4, 2, 3},
        std::tuple{"ppocr_det_1280x736.onnx", 736, 1280, 9, 2, 3},
        std::tuple{"ppocr_det_288x224.onnx", 224, 288, 0, 2, 3},
        std::tuple{"../ppocr_det_256x192_tuned.onnx", 192, 256, 0, 2, 3},
        std::tuple{"ppocr_rec_w320.onnx", 48, 320, 0, 0, 0}}) {
    const int shape[] = {1, 3, height, width};
    cv::Mat input(4, shape, CV_32F);
    cv::randu(input, -1, 1);
    int pairs = 0;     // layers that run the layer after them too
    int slices = 0;    // upsamplings handed to a convolution
    int scalings = 0;  // channel scalings left to the sum after them
    const auto forward = [&](bool stand_ins) {
      std::optional<vision::DnnLayersScope> scope;
      if (stand_ins) scope.emplace(vision::DnnLayers::in_float());
      cv::dnn::Net net = vision::load_onnx_network((*models / file).string(), file);
      net.setInput(input);
      cv::Mat out = net.forward().clone();
      for (const std::string& name : net.getLayerNames()) {
        const std::string type = net.getLayer(name)->type;
        pairs += type == "KeyfleetPointwiseDepthwise" || type == "KeyfleetStridedDepthwise" ||
                 type == "KeyfleetSubpixelDeconvolutionPair";
        slices += type == "KeyfleetNearestUpsamplingIntoConvolution";
        scalings += type == "KeyfleetScaleHandedOver";
      }
      return out;
    };
    const cv::Mat opencv = forward(false), ours = forward(true);
    EXPECT_EQ(pairs, fused) << file;
    EXPECT_EQ(slices, handed) << file;
    EXPECT_EQ(scalings, excited) << file;
    ASSERT_EQ(opencv.total(), ours.total()) << file;
    EXPECT_LT(cv::norm(opencv, ours, cv::NORM_INF), 1e-4) << file;
  }
}

// The Latin files (the converter cuts the classifier to the Latin classes and both spaces) hold
// exactly the classes ppocr::latin_classes keeps of PP-OCRv4's list, and give the whole model's
// probabilities of those classes divided by their sum: the same arg-max, in 1/50 of the last
// layer's work.
TEST(PpocrReaderWithModels, LatinRecogniserIsTheWholeOneOverTheLatinClasses) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  const int width = 160;
  const auto load = [&](const char* model, const char* keys) {
    return PpocrRecognizer({{width, (*models / model).string()}}, (*models / keys).string(),
                           {true, 0, vision::DnnLayers::in_float()});
  };
  const PpocrRecognizer whole = load("ppocr_rec_w160.onnx", "ppocr_keys_v1.txt");
  const PpocrRecognizer latin = load("ppocr_rec_latin_w160.onnx", "ppocr_keys_latin.txt");
  const auto& all = whole.classes();
  const std::vector<bool> allowed = ppocr::latin_classes(all);
  std::vector<int> kept;
  for (std::size_t c = 0; c < all.size(); ++c)
    if (allowed[c] || all[c] == "\xE3\x80\x80" || c + 1 == all.size()) kept.push_back(int(c));
  ASSERT_EQ(kept.size(), latin.classes().size());
  for (std::size_t i = 0; i < kept.size(); ++i)
    EXPECT_EQ(all[std::size_t(kept[i])], latin.classes()[i]) << i;
  EXPECT_GT(kept.size(), 100u);  // ASCII and the accented letters

  const int shape[] = {1, 3, PpocrRecognizer::kHeight, width};
  cv::Mat input(4, shape, CV_32F);
  cv::randu(input, -1, 1);
  const auto forward = [&](const char* file) {
    const vision::DnnLayersScope scope(vision::DnnLayers::in_float());
    cv::dnn::Net net = vision::load_onnx_network((*models / file).string(), file);
    net.setInput(input);
    const cv::Mat out = net.forward();
    return cv::Mat(out.size[1], out.size[2], CV_32F, const_cast<float*>(out.ptr<float>())).clone();
  };
  const cv::Mat p_all = forward("ppocr_rec_w160.onnx"),
                p_latin = forward("ppocr_rec_latin_w160.onnx");
  ASSERT_EQ(p_all.rows, p_latin.rows);
  ASSERT_EQ(p_latin.cols, int(kept.size()));
  for (int t = 0; t < p_all.rows; ++t) {
    double share = 0;
    for (const int c : kept) share += p_all.at<float>(t, c);
    for (std::size_t i = 0; i < kept.size(); ++i)
      EXPECT_NEAR(p_all.at<float>(t, kept[i]) / share, p_latin.at<float>(t, int(i)), 1e-4)
          << "step " << t << " class " << all[std::size_t(kept[i])];
  }
}

TEST(PpocrReaderWithModels, ReadsRealWordCrops) {
  KEYFLEET_REQUIRE_PPOCR_MODELS();
  KEYFLEET_REQUIRE_DATA("words_mmocr/labels.json");
  for (const bool int8 : {true, false}) {
    const auto reader = make_text_reader(ppocr_config(int8));
    const auto result = eval::evaluate_cropped_words(*reader, data_path.parent_path().string());
    EXPECT_EQ(result.words, 10u);
    // Measured 5 of 10 without the word filter, 4 (or 5: HOTEL at confidence 0.70) with it.
    EXPECT_GE(result.correct, 4u) << "ppocr read " << result.correct << "/10, int8 " << int8;
  }
}

}  // namespace
}  // namespace keyfleet::station
