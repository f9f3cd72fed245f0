// JpegCodec and jpeg_dimensions: round trips, header parsing, hostile input.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

TEST(JpegCodec, RejectsQualityOutsideOneToHundred) {
  EXPECT_THROW(JpegCodec(0), StartupError);
  EXPECT_THROW(JpegCodec(101), StartupError);
  EXPECT_THROW(JpegCodec(-5), StartupError);
  EXPECT_NO_THROW(JpegCodec(1));
  EXPECT_NO_THROW(JpegCodec(100));
}

TEST(JpegCodec, NamesItsEncodingJpeg) { EXPECT_EQ(JpegCodec(80).encoding(), "jpeg"); }

TEST(JpegCodec, RoundTripKeepsSizeAndApproximateContent) {
  const cv::Mat original = test::make_smooth_image(640, 480);
  const JpegCodec codec(90);
  const std::vector<std::uint8_t> bytes = codec.encode(original);
  ASSERT_FALSE(bytes.empty());
  ASSERT_GE(bytes.size(), 4u);
  EXPECT_EQ(bytes[0], 0xFF);
  EXPECT_EQ(bytes[1], 0xD8);

  const DecodeResult decoded = codec.decode(bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.error;
  EXPECT_TRUE(decoded.error.empty());
  ASSERT_EQ(decoded.image.cols, 640);
  ASSERT_EQ(decoded.image.rows, 480);
  ASSERT_EQ(decoded.image.type(), original.type());

  cv::Mat diff;
  cv::absdiff(original, decoded.image, diff);
  const cv::Scalar mean = cv::mean(diff);
  for (int channel = 0; channel < 3; ++channel) EXPECT_LT(mean[channel], 3.0) << channel;
}

TEST(JpegCodec, DecodesThePixelsOpenCvDecodes) {
  // libjpeg-turbo's BGR output must be cv::imdecode's, pixel for pixel (the station reads what
  // it decodes; a swapped channel or another IDCT would change the words it reads).
  const cv::Mat colour = test::make_noise_image(160, 120, 3);
  const JpegCodec codec(85);
  const std::vector<std::uint8_t> bytes = codec.encode(colour);
  const DecodeResult decoded = codec.decode(bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.error;
  const cv::Mat opencv = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(decoded.image.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(decoded.image, opencv, cv::NORM_INF), 0.0);

  // A grey JPEG comes as three equal channels, as everything after the decoder expects.
  cv::Mat grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  std::vector<std::uint8_t> grey_bytes;
  ASSERT_TRUE(cv::imencode(".jpg", grey, grey_bytes));
  const DecodeResult grey_decoded = codec.decode(grey_bytes);
  ASSERT_TRUE(grey_decoded.ok()) << grey_decoded.error;
  ASSERT_EQ(grey_decoded.image.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(grey_decoded.image, cv::imdecode(grey_bytes, cv::IMREAD_COLOR), cv::NORM_INF),
            0.0);
}

TEST(JpegCodec, LowerQualityGivesSmallerFiles) {
  const cv::Mat image = test::make_noise_image(160, 120, 3);
  EXPECT_LT(JpegCodec(20).encode(image).size(), JpegCodec(95).encode(image).size());
}

TEST(JpegDimensions, ReadsWidthAndHeightOfEncodedImage) {
  const auto bytes = test::encode_jpeg(test::make_smooth_image(640, 480));
  const auto size = jpeg_dimensions(bytes);
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, 640u);
  EXPECT_EQ(size->height, 480u);
}

TEST(JpegDimensions, ReadsGrayscaleAndOddSizes) {
  cv::Mat gray(37, 101, CV_8UC1, cv::Scalar(90));
  const auto size = jpeg_dimensions(test::encode_jpeg(gray));
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, 101u);
  EXPECT_EQ(size->height, 37u);
}

TEST(JpegDimensions, NulloptForEmptyBytes) { EXPECT_FALSE(jpeg_dimensions({}).has_value()); }

TEST(JpegDimensions, NulloptForRandomBytes) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    EXPECT_FALSE(jpeg_dimensions(test::random_bytes(4096, seed)).has_value()) << seed;
  }
}

TEST(JpegDimensions, NulloptForRandomBytesAfterAStartOfImageMarker) {
  for (unsigned seed = 1; seed <= 50; ++seed) {
    auto bytes = test::random_bytes(512, seed);
    bytes[0] = 0xFF;
    bytes[1] = 0xD8;
    // Random data may by chance look like a segment; it must never read out of bounds
    // (checked under sanitizers) and must not report a zero size.
    const auto size = jpeg_dimensions(bytes);
    if (size) {
      EXPECT_GT(size->width, 0u);
      EXPECT_GT(size->height, 0u);
    }
  }
}

TEST(JpegDimensions, NulloptForPng) {
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", test::make_smooth_image(64, 48), png));
  EXPECT_FALSE(jpeg_dimensions(png).has_value());
}

TEST(JpegDimensions, NulloptWhenCutBeforeTheFrameHeader) {
  const auto bytes = test::encode_jpeg(test::make_smooth_image(64, 48));
  const auto sof = test::find_sof_marker(bytes);
  ASSERT_TRUE(sof.has_value());
  for (std::size_t cut = 0; cut < *sof + 9; ++cut) {
    const std::vector<std::uint8_t> prefix(bytes.begin(), bytes.begin() + cut);
    EXPECT_FALSE(jpeg_dimensions(prefix).has_value()) << "cut at " << cut;
  }
}

TEST(JpegDimensions, ReportsHugeSizeClaimedByAnEditedHeader) {
  const auto edited =
      test::with_sof_size(test::encode_jpeg(test::make_smooth_image(640, 480)), 60000, 60000);
  const auto size = jpeg_dimensions(edited);
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, 60000u);
  EXPECT_EQ(size->height, 60000u);
}

TEST(JpegDimensions, NulloptWhenHeaderClaimsZeroSize) {
  const auto edited =
      test::with_sof_size(test::encode_jpeg(test::make_smooth_image(64, 48)), 0, 48);
  EXPECT_FALSE(jpeg_dimensions(edited).has_value());
}

struct GarbageCase {
  const char* name;
  std::vector<std::uint8_t> bytes;
};

std::vector<GarbageCase> garbage_cases() {
  std::vector<std::uint8_t> png;
  cv::imencode(".png", test::make_smooth_image(32, 32), png);
  const auto jpeg = test::encode_jpeg(test::make_smooth_image(64, 48));
  const auto sof = test::find_sof_marker(jpeg);
  const std::size_t header_end = sof ? *sof + 2 + ((jpeg[*sof + 2] << 8) | jpeg[*sof + 3]) : 0;
  std::vector<std::uint8_t> header_only(jpeg.begin(), jpeg.begin() + header_end);
  header_only.push_back(0xFF);
  header_only.push_back(0xD9);
  auto jpeg_start_then_noise = test::random_bytes(2000, 9);
  jpeg_start_then_noise[0] = 0xFF;
  jpeg_start_then_noise[1] = 0xD8;
  return {{"Empty", {}},
          {"RandomBytes", test::random_bytes(2000, 7)},
          {"Png", png},
          {"StartMarkerThenNoise", jpeg_start_then_noise},
          {"HeadersWithoutScan", header_only}};
}

TEST(JpegCodecDecode, GarbageGivesErrorAndNeverThrows) {
  const JpegCodec codec(85);
  for (const auto& c : garbage_cases()) {
    SCOPED_TRACE(c.name);
    DecodeResult result;
    EXPECT_NO_THROW(result = codec.decode(c.bytes));
    EXPECT_FALSE(result.ok());
    EXPECT_TRUE(result.image.empty());
    EXPECT_FALSE(result.error.empty());
  }
}

}  // namespace
}  // namespace keyfleet
