// `keyfleet ocr eval --encoding`: the specs, and a photo sent at a robot's encoding (plain and
// text-aware, with a test double for the semantic model).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/photo_encoding.hpp"

namespace keyfleet::eval {
namespace {

TEST(EncodingSpec, QualityScaleAndTextAware) {
  const EvalEncoding plain = parse_encoding_spec("q55=55");
  EXPECT_EQ(plain.name, "q55");
  EXPECT_EQ(plain.jpeg_quality, 55);
  EXPECT_DOUBLE_EQ(plain.scale, 1.0);
  EXPECT_FALSE(plain.text_aware);
  const EvalEncoding aware = parse_encoding_spec("ta40=40@0.5+text");
  EXPECT_EQ(aware.jpeg_quality, 40);
  EXPECT_DOUBLE_EQ(aware.scale, 0.5);
  EXPECT_TRUE(aware.text_aware);
}

TEST(EncodingSpec, BadSpecsNameWhatIsWrong) {
  const auto error = [](const std::string& spec) {
    try {
      parse_encoding_spec(spec);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("55").find("no NAME="), std::string::npos);
  EXPECT_NE(error("a=0").find("quality must be a whole number from 1 to 100"), std::string::npos);
  EXPECT_NE(error("a=55x").find("quality"), std::string::npos);
  EXPECT_NE(error("a=55@0").find("scale must be in (0, 1]"), std::string::npos);
  EXPECT_NE(error("a=55@1.5").find("scale"), std::string::npos);
  EXPECT_NE(error("a=55@").find("scale"), std::string::npos);
  EXPECT_NE(error("a|b=55").find("name must be"), std::string::npos);
}

// Marks one rectangle of the frame as text (at the frame's own size).
class RectangleSegmenter final : public vision::TextSegmenter {
 public:
  explicit RectangleSegmenter(cv::Rect text) : text_(text) {}
  std::vector<cv::Mat> segment(const std::vector<cv::Mat>& frames) override {
    std::vector<cv::Mat> masks;
    for (const auto& f : frames) {
      cv::Mat mask(f.size(), CV_8U, cv::Scalar(0));
      mask(text_).setTo(255);
      masks.push_back(mask);
    }
    return masks;
  }
  const vision::SegmenterInfo& info() const override { return info_; }

 private:
  cv::Rect text_;
  vision::SegmenterInfo info_;
};

// Fine black-and-white stripes one pixel wide: lost by any downscale, kept where pixels are.
cv::Mat striped_photo() {
  cv::Mat photo(240, 320, CV_8UC3);
  for (int y = 0; y < photo.rows; ++y)
    for (int x = 0; x < photo.cols; ++x)
      photo.at<cv::Vec3b>(y, x) = (x % 2) ? cv::Vec3b(255, 255, 255) : cv::Vec3b(0, 0, 0);
  return photo;
}

double stripe_contrast(const cv::Mat& image, cv::Rect where) {
  cv::Mat grey, dx;
  cv::cvtColor(image(where), grey, cv::COLOR_BGR2GRAY);
  cv::Sobel(grey, dx, CV_32F, 1, 0);
  return cv::mean(cv::abs(dx))[0];
}

TEST(PhotoLink, PlainScaledPhotoComesBackSmallerWithItsScale) {
  const auto link = make_photo_link(parse_encoding_spec("h=70@0.5"), 4, nullptr);
  const ReceivedPhoto received = link(striped_photo());
  EXPECT_EQ(received.image.size(), cv::Size(160, 120));
  EXPECT_DOUBLE_EQ(received.sx, 2.0);
  EXPECT_DOUBLE_EQ(received.sy, 2.0);
  EXPECT_GT(received.bytes, 0u);
}

TEST(PhotoLink, TextAwareKeepsTheSizeAndTheTextSharp) {
  const cv::Rect text(100, 80, 80, 40);
  const auto link = make_photo_link(parse_encoding_spec("ta=90@0.5+text"), 4,
                                    std::make_shared<RectangleSegmenter>(text));
  const ReceivedPhoto received = link(striped_photo());
  ASSERT_EQ(received.image.size(), cv::Size(320, 240));
  EXPECT_DOUBLE_EQ(received.sx, 1.0);
  const double inside = stripe_contrast(received.image, text);
  const double outside = stripe_contrast(received.image, cv::Rect(10, 10, 60, 40));
  EXPECT_GT(inside, 4 * outside) << "inside " << inside << ", outside " << outside;
}

TEST(PhotoLink, TextAwareWithoutASemanticModelIsRefused) {
  EXPECT_THROW(make_photo_link(parse_encoding_spec("ta=40@0.5+text"), 4, nullptr), StartupError);
}

}  // namespace
}  // namespace keyfleet::eval
