// find_keyframe_problem: what the station accepts, and why it rejects the rest.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/station/keyframe_validator.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

class KeyframeValidatorTest : public ::testing::Test {
 protected:
  // The rejection reason; fails the test when the keyframe is accepted.
  std::string reason_for(const Keyframe& k) {
    const auto problem = find_keyframe_problem(k, limits_, codec_);
    EXPECT_TRUE(problem.has_value()) << "keyframe was accepted";
    return problem.value_or("");
  }

  StationLimits limits_;
  JpegCodec codec_{90};
  Keyframe valid_ = keyfleet::test::make_valid_keyframe("drone_0", 3);
};

void expect_mentions(const std::string& reason, const std::string& what) {
  EXPECT_NE(reason.find(what), std::string::npos) << "reason: " << reason;
}

TEST_F(KeyframeValidatorTest, AcceptsAValidJpegKeyframe) {
  EXPECT_EQ(find_keyframe_problem(valid_, limits_, codec_), std::nullopt);
}

// The pixels it decoded come out for the analysis (which then decodes nothing); a rejected
// keyframe gives none.
TEST_F(KeyframeValidatorTest, GivesThePixelsItDecodedOnlyForAnAcceptedKeyframe) {
  cv::Mat decoded;
  ASSERT_EQ(find_keyframe_problem(valid_, limits_, codec_, &decoded), std::nullopt);
  const DecodeResult direct = codec_.decode(valid_.image);
  ASSERT_TRUE(direct.ok());
  ASSERT_EQ(decoded.size(), direct.image.size());
  ASSERT_EQ(decoded.type(), direct.image.type());
  EXPECT_EQ(cv::norm(decoded, direct.image, cv::NORM_INF), 0);
  Keyframe bad = valid_;
  bad.width += 1;  // the claimed size is not the header's
  cv::Mat none;
  EXPECT_NE(find_keyframe_problem(bad, limits_, codec_, &none), std::nullopt);
  EXPECT_TRUE(none.empty());
}

TEST_F(KeyframeValidatorTest, AcceptsSizeExactlyAtTheLimits) {
  limits_.max_width = valid_.width;
  limits_.max_height = valid_.height;
  limits_.max_image_bytes = valid_.image.size();
  EXPECT_EQ(find_keyframe_problem(valid_, limits_, codec_), std::nullopt);
}

TEST_F(KeyframeValidatorTest, RejectsRobotIdWithForbiddenCharacters) {
  valid_.robot_id = "bad id!";
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "robot id");
  expect_mentions(reason, "bad id!");
}

TEST_F(KeyframeValidatorTest, RejectsOverlongRobotIdWithoutEchoingAllOfIt) {
  valid_.robot_id = std::string(100, 'r');
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "robot id");
  EXPECT_EQ(reason.find(std::string(65, 'r')), std::string::npos) << reason;
}

TEST_F(KeyframeValidatorTest, RejectsEmptyRobotId) {
  valid_.robot_id.clear();
  expect_mentions(reason_for(valid_), "robot id");
}

TEST_F(KeyframeValidatorTest, RejectsPngEncoding) {
  valid_.encoding = "png";
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "encoding");
  expect_mentions(reason, "png");
}

TEST_F(KeyframeValidatorTest, RejectsEmptyImage) {
  valid_.image.clear();
  expect_mentions(reason_for(valid_), "empty image");
}

TEST_F(KeyframeValidatorTest, RejectsImageOverMaxImageBytes) {
  limits_.max_image_bytes = valid_.image.size() - 1;
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "max_image_bytes");
  expect_mentions(reason, std::to_string(valid_.image.size()));
}

TEST_F(KeyframeValidatorTest, RejectsClaimedZeroWidth) {
  valid_.width = 0;
  expect_mentions(reason_for(valid_), "claimed size 0x48");
}

TEST_F(KeyframeValidatorTest, RejectsClaimedZeroHeight) {
  valid_.height = 0;
  expect_mentions(reason_for(valid_), "claimed size 64x0");
}

TEST_F(KeyframeValidatorTest, RejectsClaimedSizeAboveLimits) {
  limits_.max_width = 32;
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "claimed size 64x48");
  expect_mentions(reason, "32x4096");
}

TEST_F(KeyframeValidatorTest, RejectsClaimedHeightAboveLimits) {
  valid_.height = 9000;
  expect_mentions(reason_for(valid_), "claimed size 64x9000");
}

TEST_F(KeyframeValidatorTest, RejectsHeaderSizeDifferentFromClaimed) {
  valid_.width = 48;
  valid_.height = 64;
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "JPEG header says 64x48");
  expect_mentions(reason, "48x64");
}

TEST_F(KeyframeValidatorTest, RejectsHugeHeaderBeforeDecoding) {
  valid_.image = keyfleet::test::with_sof_size(valid_.image, 60000, 60000);
  expect_mentions(reason_for(valid_), "60000x60000");
}

TEST_F(KeyframeValidatorTest, RejectsHugeHeaderEvenWhenClaimedSizeMatches) {
  valid_.image = keyfleet::test::with_sof_size(valid_.image, 60000, 60000);
  valid_.width = 60000;
  valid_.height = 60000;
  expect_mentions(reason_for(valid_), "claimed size 60000x60000");
}

TEST_F(KeyframeValidatorTest, RejectsRandomBytes) {
  valid_.image = keyfleet::test::random_bytes(5000, 11);
  expect_mentions(reason_for(valid_), "JPEG");
}

TEST_F(KeyframeValidatorTest, RejectsPngBytesLabelledJpeg) {
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", keyfleet::test::make_smooth_image(64, 48), png));
  valid_.image = png;
  expect_mentions(reason_for(valid_), "JPEG");
}

TEST_F(KeyframeValidatorTest, RejectsJpegCutInHalf) {
  Keyframe big = keyfleet::test::make_valid_keyframe("drone_0", 1, 320, 240);
  big.image = keyfleet::test::encode_jpeg(keyfleet::test::make_noise_image(320, 240, 5));
  ASSERT_EQ(find_keyframe_problem(big, limits_, codec_), std::nullopt);
  big.image.resize(big.image.size() / 2);
  expect_mentions(reason_for(big), "truncated");
}

TEST_F(KeyframeValidatorTest, RejectsJpegWhoseDataDoesNotDecode) {
  // Headers up to the frame header, then straight to end-of-image: no scan to decode.
  const auto sof = keyfleet::test::find_sof_marker(valid_.image);
  ASSERT_TRUE(sof.has_value());
  const std::size_t length = (valid_.image[*sof + 2] << 8) | valid_.image[*sof + 3];
  valid_.image.resize(*sof + 2 + length);
  valid_.image.push_back(0xFF);
  valid_.image.push_back(0xD9);
  const std::string reason = reason_for(valid_);
  expect_mentions(reason, "JPEG");
}

// Counts decode() calls: the cost checks must refuse before the decoder runs.
class CountingCodec final : public ImageCodec {
 public:
  std::string encoding() const override { return inner_.encoding(); }
  std::vector<std::uint8_t> encode(const cv::Mat& image) const override {
    return inner_.encode(image);
  }
  DecodeResult decode(const std::vector<std::uint8_t>& bytes) const override {
    ++decodes;
    return inner_.decode(bytes);
  }
  mutable int decodes = 0;

 private:
  JpegCodec inner_{90};
};

TEST_F(KeyframeValidatorTest, AcceptsAProgressiveJpegWithinTheScanBound) {
  cv::imencode(".jpg", keyfleet::test::make_smooth_image(64, 48), valid_.image,
               {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  EXPECT_EQ(find_keyframe_problem(valid_, limits_, codec_), std::nullopt);
}

TEST_F(KeyframeValidatorTest, RefusesCostlyJpegsBeforeDecodingThem) {
  CountingCodec counting;
  ASSERT_EQ(find_keyframe_problem(valid_, limits_, counting), std::nullopt);
  ASSERT_EQ(counting.decodes, 1);

  Keyframe progressive = valid_;
  cv::imencode(".jpg", keyfleet::test::make_smooth_image(64, 48), progressive.image,
               {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  limits_.max_scans = 2;
  auto reason = find_keyframe_problem(progressive, limits_, counting);
  ASSERT_TRUE(reason.has_value());
  expect_mentions(*reason, "max_scans 2");

  limits_ = {};
  Keyframe lossless = valid_;
  lossless.image[*keyfleet::test::find_sof_marker(lossless.image) + 1] = 0xC3;
  reason = find_keyframe_problem(lossless, limits_, counting);
  ASSERT_TRUE(reason.has_value());
  expect_mentions(*reason, "lossless");

  // A small stream whose header (and claim) asks for a 4000x3000 frame.
  Keyframe bomb = valid_;
  bomb.image = keyfleet::test::with_sof_size(bomb.image, 4000, 3000);
  bomb.width = 4000;
  bomb.height = 3000;
  reason = find_keyframe_problem(bomb, limits_, counting);
  ASSERT_TRUE(reason.has_value());
  expect_mentions(*reason, "pixels per byte");

  EXPECT_EQ(counting.decodes, 1) << "a refused JPEG was decoded";
}

TEST_F(KeyframeValidatorTest, DefaultLimitsRefuseTheOldMaximumFrame) {
  // 8192x8192 from an 8 MB sample was once accepted and decoded.
  valid_.image = keyfleet::test::with_sof_size(valid_.image, 8192, 8192);
  valid_.width = valid_.height = 8192;
  expect_mentions(reason_for(valid_), "claimed size 8192x8192 outside 1x1..4096x4096");
}

}  // namespace
}  // namespace keyfleet::station
