// The station's text reading: ICDAR 2015 end-to-end metric on hand-made cases, the ground
// truth readers, and the real engines on generated and real images.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <fstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/text_dataset_eval.hpp"
#include "keyfleet/eval/text_eval.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

using namespace ::keyfleet::eval;

GtWord gt(int x, int y, int w, int h, const std::string& text) {
  GtWord word;
  word.quad = {cv::Point2f(float(x), float(y)), cv::Point2f(float(x + w), float(y)),
               cv::Point2f(float(x + w), float(y + h)), cv::Point2f(float(x), float(y + h))};
  word.text = text;
  word.dont_care = text == "###";
  return word;
}

ReadWord det(int x, int y, int w, int h, const std::string& text) {
  return ReadWord{text, 0.9f, cv::Rect(x, y, w, h)};
}

TEST(EndToEndMetric, PerfectReadingScoresOne) {
  const std::vector<GtWord> truth = {gt(10, 10, 100, 30, "HOTEL"), gt(10, 60, 80, 30, "Grand")};
  const auto c =
      match_end_to_end(truth, {det(10, 60, 80, 30, "Grand"), det(10, 10, 100, 30, "HOTEL")});
  EXPECT_EQ(c.matched, 2u);
  EXPECT_DOUBLE_EQ(c.recall(), 1.0);
  EXPECT_DOUBLE_EQ(c.precision(), 1.0);
  EXPECT_DOUBLE_EQ(c.f_score(), 1.0);
}

TEST(EndToEndMetric, OneMissLowersRecallOnly) {
  const std::vector<GtWord> truth = {gt(10, 10, 100, 30, "HOTEL"), gt(10, 60, 80, 30, "Grand")};
  const auto c = match_end_to_end(truth, {det(10, 10, 100, 30, "HOTEL")});
  EXPECT_DOUBLE_EQ(c.recall(), 0.5);
  EXPECT_DOUBLE_EQ(c.precision(), 1.0);
  EXPECT_NEAR(c.f_score(), 2 * 0.5 / 1.5, 1e-12);
}

TEST(EndToEndMetric, FalsePositiveLowersPrecisionOnly) {
  const std::vector<GtWord> truth = {gt(10, 10, 100, 30, "HOTEL")};
  const auto c =
      match_end_to_end(truth, {det(10, 10, 100, 30, "HOTEL"), det(300, 300, 50, 20, "EXIT")});
  EXPECT_DOUBLE_EQ(c.recall(), 1.0);
  EXPECT_DOUBLE_EQ(c.precision(), 0.5);
}

TEST(EndToEndMetric, WrongTextAtTheRightPlaceIsBothAMissAndAFalsePositive) {
  const auto c = match_end_to_end({gt(10, 10, 100, 30, "HOTEL")}, {det(10, 10, 100, 30, "H0TEL")});
  EXPECT_EQ(c.matched, 0u);
  EXPECT_EQ(c.gt_words, 1u);
  EXPECT_EQ(c.detections, 1u);
}

TEST(EndToEndMetric, DontCareWordsAndDetectionsOnThemAreIgnored) {
  const std::vector<GtWord> truth = {gt(10, 10, 100, 30, "HOTEL"), gt(200, 10, 100, 30, "###")};
  const auto c =
      match_end_to_end(truth, {det(10, 10, 100, 30, "HOTEL"), det(205, 12, 90, 26, "xyz")});
  EXPECT_EQ(c.gt_words, 1u);
  EXPECT_EQ(c.detections, 1u);
  EXPECT_DOUBLE_EQ(c.precision(), 1.0);
  EXPECT_DOUBLE_EQ(c.recall(), 1.0);
}

TEST(EndToEndMetric, TranscriptionsCompareCaseInsensitively) {
  const auto c = match_end_to_end({gt(10, 10, 100, 30, "Hotel")}, {det(10, 10, 100, 30, "hOTEL")});
  EXPECT_EQ(c.matched, 1u);
}

TEST(EndToEndMetric, GtEdgePunctuationMayBeMissingAsInTheOfficialScript) {
  EXPECT_TRUE(transcriptions_match("[06]", "06"));
  EXPECT_TRUE(transcriptions_match("NOTHING?", "nothing"));
  EXPECT_FALSE(transcriptions_match("NOTHING?", "nothing", false));
  EXPECT_FALSE(transcriptions_match("62-03", "6203"));
  EXPECT_FALSE(transcriptions_match("06", "[06]"));  // only the GT's marks may be dropped
}

TEST(EndToEndMetric, IouJustBelowHalfFailsJustAboveMatches) {
  // GT 100x30 at x=0; a 100x30 detection shifted by d has IoU (100-d)/(100+d).
  // d = 34: 66/134 = 0.4925; d = 33: 67/133 = 0.5038.
  const std::vector<GtWord> truth = {gt(0, 0, 100, 30, "HOTEL")};
  EXPECT_LT(quad_rect_iou(truth[0].quad, cv::Rect(34, 0, 100, 30)), 0.5);
  EXPECT_EQ(match_end_to_end(truth, {det(34, 0, 100, 30, "HOTEL")}).matched, 0u);
  EXPECT_GT(quad_rect_iou(truth[0].quad, cv::Rect(33, 0, 100, 30)), 0.5);
  EXPECT_EQ(match_end_to_end(truth, {det(33, 0, 100, 30, "HOTEL")}).matched, 1u);
}

TEST(EndToEndMetric, MatchingIsOneToOne) {
  const auto c = match_end_to_end({gt(10, 10, 100, 30, "HOTEL")},
                                  {det(10, 10, 100, 30, "HOTEL"), det(12, 10, 100, 30, "HOTEL")});
  EXPECT_EQ(c.matched, 1u);
  EXPECT_EQ(c.detections, 2u);  // the duplicate is a false positive
}

TEST(EndToEndMetric, PolygonIouOfATiltedQuad) {
  GtWord diamond;
  diamond.quad = {cv::Point2f(50, 0), cv::Point2f(100, 50), cv::Point2f(50, 100),
                  cv::Point2f(0, 50)};  // area 5000, inscribed in the 100x100 square
  EXPECT_NEAR(quad_rect_iou(diamond.quad, cv::Rect(0, 0, 100, 100)), 0.5, 1e-6);
  EXPECT_DOUBLE_EQ(quad_rect_iou(diamond.quad, cv::Rect(200, 200, 10, 10)), 0.0);
}

TEST(GroundTruthReaders, IcdarFileWithBomCommasAndDontCare) {
  test::TempDir dir;
  {
    std::ofstream out(dir.file("gt_img_1.txt"), std::ios::binary);
    out << "\xEF\xBB\xBF"
           "377,117,463,117,465,130,378,130,Genaxis Theatre\r\n"
        << "374,155,409,155,409,170,374,170,###\r\n"
        << "1,2,3,4,5,6,7,8,a,b\n";
  }
  const auto words = read_icdar_gt(dir.file("gt_img_1.txt"));
  ASSERT_EQ(words.size(), 3u);
  EXPECT_EQ(words[0].text, "Genaxis Theatre");
  EXPECT_FLOAT_EQ(words[0].quad[0].x, 377);
  EXPECT_FLOAT_EQ(words[0].quad[2].y, 130);
  EXPECT_TRUE(words[1].dont_care);
  EXPECT_EQ(words[2].text, "a,b");
  EXPECT_THROW(read_icdar_gt(dir.file("missing.txt")), StartupError);
  {
    std::ofstream out(dir.file("bad.txt"));
    out << "1,2,3,x\n";
  }
  EXPECT_THROW(read_icdar_gt(dir.file("bad.txt")), StartupError);
}

TEST(EndToEndMetric, ADetectionWithAQuadIsComparedByItsQuad) {
  // A slanted word: its bounding rectangle overlaps the truth by less than half, its quad fully.
  GtWord slanted{
      {cv::Point2f(0, 0), cv::Point2f(100, 40), cv::Point2f(100, 60), cv::Point2f(0, 20)}, "SLANT"};
  ReadWord read = det(0, 0, 100, 60, "SLANT");
  EXPECT_EQ(match_end_to_end({slanted}, {read}).matched, 0u);
  read.quad = slanted.quad;
  EXPECT_EQ(match_end_to_end({slanted}, {read}).matched, 1u);
  EXPECT_NEAR(quad_iou(slanted.quad, read.quad), 1.0, 1e-6);
}

TEST(GroundTruthReaders, IcdarWordListWithBomAndEscapedQuotes) {
  test::TempDir dir;
  {
    std::ofstream out(dir.file("gt.txt"), std::ios::binary);
    out << "\xEF\xBB\xBF"
           "word_1.png, \"Genaxis Theatre\"\r\n"
        << "word_2.png, \"\\\"SCAN\\\"\"\r\n";
  }
  const auto words = read_word_set(dir.path().string());
  ASSERT_EQ(words.size(), 2u);
  EXPECT_EQ(words[0].text, "Genaxis Theatre");
  EXPECT_EQ(std::filesystem::path(words[0].image_path).filename(), "word_1.png");
  EXPECT_EQ(words[1].text, "\"SCAN\"");
  {
    std::ofstream out(dir.file("gt.txt"));
    out << "word_1.png Genaxis\n";
  }
  EXPECT_THROW(read_word_set(dir.path().string()), StartupError);
  EXPECT_THROW(read_word_set(dir.file("nowhere")), StartupError);
}

TEST(WordFilter, WordsTheFrameCutsAreRecognised) {
  const cv::Size frame(640, 480);
  EXPECT_FALSE(cut_by_frame(cv::Rect(10, 10, 100, 20), frame, 2));
  EXPECT_TRUE(cut_by_frame(cv::Rect(2, 10, 100, 20), frame, 2));
  EXPECT_TRUE(cut_by_frame(cv::Rect(540, 10, 98, 20), frame, 2));
  EXPECT_TRUE(cut_by_frame(cv::Rect(10, 458, 100, 20), frame, 2));
  EXPECT_FALSE(cut_by_frame(cv::Rect(0, 0, 640, 480), frame, -1));
}

TEST(GroundTruthReaders, MmocrLabels) {
  KEYFLEET_REQUIRE_DATA("words_mmocr/labels.json");
  const auto words = read_mmocr_labels(data_path.string());
  ASSERT_EQ(words.size(), 10u);
  EXPECT_EQ(words[0].text, "GRAND");
  EXPECT_TRUE(std::filesystem::exists(words[0].image_path));
}

TEST(CroppedWordReading, JoinsWordsLeftToRight) {
  EXPECT_EQ(cropped_word_reading({det(50, 0, 10, 10, "TEL"), det(0, 0, 10, 10, "HO")}), "HOTEL");
}

TEST(WordFilter, DropsJunkKeepsWords) {
  TextReadingConfig p;
  p.min_confidence = 0.5f;
  p.min_word_length = 2;
  EXPECT_TRUE(keep_word(det(0, 0, 10, 10, "HOTEL"), p));
  EXPECT_TRUE(keep_word(det(0, 0, 10, 10, "03/09/2009"), p));
  EXPECT_TRUE(keep_word(det(0, 0, 10, 10, "Café"), p));
  EXPECT_FALSE(keep_word(det(0, 0, 10, 10, "~-="), p));
  EXPECT_FALSE(keep_word(det(0, 0, 10, 10, "a/|"), p));
  EXPECT_FALSE(keep_word(det(0, 0, 10, 10, "a"), p));
  EXPECT_FALSE(keep_word(ReadWord{"HOTEL", 0.3f, cv::Rect(0, 0, 10, 10)}, p));
}

// A big word on a textured background, like a shop sign on a wall.
cv::Mat sign_image(const std::string& word, cv::Rect& drawn) {
  cv::Mat image(480, 640, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(image, cv::RNG::UNIFORM, cv::Scalar(90, 100, 110), cv::Scalar(170, 180, 190));
  cv::GaussianBlur(image, image, cv::Size(5, 5), 0);
  for (int i = 0; i < 30; ++i)
    cv::line(image, cv::Point(rng.uniform(0, 640), rng.uniform(0, 480)),
             cv::Point(rng.uniform(0, 640), rng.uniform(0, 480)), cv::Scalar(60, 70, 80), 2);
  const int font = cv::FONT_HERSHEY_DUPLEX;
  const double scale = 2.5;
  const int thickness = 5;
  int baseline = 0;
  const cv::Size size = cv::getTextSize(word, font, scale, thickness, &baseline);
  const cv::Point origin(120, 260);
  drawn = cv::Rect(origin.x, origin.y - size.height, size.width, size.height);
  cv::rectangle(image, drawn + cv::Size(40, 40) - cv::Point(20, 20), cv::Scalar(235, 240, 245),
                cv::FILLED);
  cv::putText(image, word, origin, font, scale, cv::Scalar(30, 20, 120), thickness, cv::LINE_AA);
  return image;
}

class EveryEngine : public ::testing::TestWithParam<std::string> {
 protected:
  std::unique_ptr<TextReader> reader() {
    TextReadingConfig params;
    params.engine = GetParam();
    return make_text_reader(params);
  }
};

TEST_P(EveryEngine, FindsADrawnWordWhereItWasDrawn) {
  cv::Rect drawn;
  const cv::Mat image = sign_image("HOTEL", drawn);
  const auto words = reader()->read(image);
  bool found = false;
  for (const auto& w : words)
    if (transcriptions_match("HOTEL", w.text, false) && (w.box & drawn).area() > 0) found = true;
  EXPECT_TRUE(found) << "read " << words.size() << " words, none is HOTEL over " << drawn;
}

TEST_P(EveryEngine, BadImagesGiveNoWordsAndNoThrow) {
  const auto r = reader();
  EXPECT_TRUE(r->read(cv::Mat()).empty());
  EXPECT_TRUE(r->read(cv::Mat(1, 1, CV_8UC3, cv::Scalar::all(0))).empty());
  EXPECT_TRUE(r->read(cv::Mat(3, 500, CV_8UC3, cv::Scalar::all(255))).empty());
  EXPECT_TRUE(r->read(cv::Mat(100, 100, CV_32FC3, cv::Scalar::all(0.5))).empty());
  EXPECT_TRUE(r->read(cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(128))).empty());
  // Uniform noise: whatever comes out must pass the junk filter (here: nothing).
  EXPECT_TRUE(r->read(test::make_noise_image(640, 480, 3)).empty());
}

INSTANTIATE_TEST_SUITE_P(TextReader, EveryEngine,
                         ::testing::Values("tesseract", "mininet+tesseract"), [](const auto& info) {
                           return info.param == "tesseract" ? std::string("Tesseract")
                                                            : std::string("MiniNetTesseract");
                         });

TEST(TextReaderFactory, StartupErrors) {
  TextReadingConfig params;
  params.engine = "no-such-engine";
  EXPECT_THROW(make_text_reader(params), StartupError);
  params = TextReadingConfig{};
  params.engine = "tesseract";
  params.tesseract.tessdata_dir = "/nonexistent/tessdata";
  EXPECT_THROW(make_text_reader(params), StartupError);
  params = TextReadingConfig{};
  params.engine = "tesseract";
  params.tesseract.language = "xx_missing";
  EXPECT_THROW(make_text_reader(params), StartupError);
  params = TextReadingConfig{};
  params.min_confidence = 2;
  EXPECT_THROW(make_text_reader(params), StartupError);
  params = TextReadingConfig{};
  params.engine = "mininet+tesseract";
  params.mininet.segmenter_model = "/nonexistent/model.onnx";
  EXPECT_THROW(make_text_reader(params), StartupError);
}

TEST(TextReaderFactory, CorruptTraineddataIsAStartupError) {
  test::TempDir dir;
  {
    std::ofstream out(dir.file("eng.traineddata"), std::ios::binary);
    out << "not a traineddata file";
  }
  TextReadingConfig params;
  params.engine = "tesseract";
  params.tesseract.tessdata_dir = dir.path().string();
  EXPECT_THROW(make_text_reader(params), StartupError);
}

TEST(TextReaderOnRealData, ReadsCroppedWords) {
  KEYFLEET_REQUIRE_DATA("words_mmocr/labels.json");
  TextReadingConfig params;
  params.engine = "tesseract";
  const auto reader = make_text_reader(params);
  const auto result = evaluate_cropped_words(*reader, data_path.parent_path().string());
  EXPECT_EQ(result.words, 10u);
  // Measured 2 of 10 (`keyfleet ocr eval`): most crops are loose and low.
  EXPECT_GE(result.correct, 1u) << "tesseract read " << result.correct << "/10";
}

}  // namespace
}  // namespace keyfleet::station
