// inspect_jpeg and find_jpeg_cost_problem: JPEGs from OpenCV's encoder, then edited byte by byte.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/common/jpeg_header.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes encode(const cv::Mat& image, const std::vector<int>& params = {}) {
  Bytes bytes;
  if (!cv::imencode(".jpg", image, bytes, params)) throw std::runtime_error("imencode failed");
  return bytes;
}

Bytes colour_jpeg(int width = 64, int height = 48) {
  return encode(test::make_smooth_image(width, height));
}

// Offset of the first segment with this marker, walking the segments before the first scan.
std::size_t segment_at(const Bytes& jpeg, std::uint8_t marker) {
  std::size_t pos = 2;
  while (pos + 4 <= jpeg.size() && jpeg[pos] == 0xFF) {
    if (jpeg[pos + 1] == marker) return pos;
    if (jpeg[pos + 1] == 0xDA) break;
    pos += 2 + ((std::size_t{jpeg[pos + 2]} << 8) | jpeg[pos + 3]);
  }
  throw std::runtime_error("test JPEG has no such segment");
}

// The first scan (its header and entropy-coded data) repeated `copies` more times before EOI.
Bytes with_repeated_scan(Bytes jpeg, int copies) {
  const std::size_t sos = segment_at(jpeg, 0xDA);
  const Bytes scan(jpeg.begin() + static_cast<std::ptrdiff_t>(sos), jpeg.end() - 2);
  for (int i = 0; i < copies; ++i) jpeg.insert(jpeg.end() - 2, scan.begin(), scan.end());
  return jpeg;
}

JpegHeader inspected(const Bytes& jpeg) {
  const JpegInspection result = inspect_jpeg(jpeg);
  EXPECT_TRUE(result.ok()) << result.error;
  return result.header;
}

std::string cost_problem(const Bytes& jpeg, const StationLimits& limits = {}) {
  const auto problem = find_jpeg_cost_problem(inspected(jpeg), jpeg.size(), limits);
  EXPECT_TRUE(problem.has_value()) << "the JPEG was found cheap";
  return problem.value_or("");
}

void expect_mentions(const std::string& text, const std::string& what) {
  EXPECT_NE(text.find(what), std::string::npos) << text;
}

TEST(InspectJpeg, ReadsABaselineColourJpeg) {
  const JpegHeader h = inspected(colour_jpeg(640, 480));
  EXPECT_EQ(h.sof_marker, 0xC0);
  EXPECT_EQ(h.process, JpegProcess::kBaseline);
  EXPECT_EQ(h.precision, 8);
  EXPECT_EQ(h.size.width, 640u);
  EXPECT_EQ(h.size.height, 480u);
  ASSERT_EQ(h.components.size(), 3u);
  EXPECT_EQ(h.components[0].horizontal_sampling, 2);  // 4:2:0
  EXPECT_EQ(h.components[0].vertical_sampling, 2);
  EXPECT_EQ(h.components[1].horizontal_sampling, 1);
  EXPECT_EQ(h.scans, 1u);
  EXPECT_EQ(h.restart_markers, 0u);
}

TEST(InspectJpeg, ReadsAGreyJpeg) {
  const JpegHeader h = inspected(encode(cv::Mat(37, 101, CV_8UC1, cv::Scalar(90))));
  EXPECT_EQ(h.components.size(), 1u);
  EXPECT_EQ(h.scans, 1u);
  EXPECT_EQ(h.size.width, 101u);
}

TEST(InspectJpeg, CountsEveryScanOfAProgressiveJpeg) {
  const Bytes jpeg = encode(test::make_smooth_image(64, 48), {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  const JpegHeader h = inspected(jpeg);
  EXPECT_EQ(h.process, JpegProcess::kProgressive);
  EXPECT_GE(h.scans, 6u);
  EXPECT_EQ(find_jpeg_cost_problem(h, jpeg.size(), StationLimits{}), std::nullopt)
      << "the default limits take an ordinary progressive JPEG";
}

TEST(InspectJpeg, SkipsStuffedBytesAndCountsRestartMarkers) {
  // Noise makes entropy-coded data full of stuffed 0xFF00; one restart per 16x16 MCU.
  const Bytes jpeg = encode(test::make_noise_image(64, 48, 3),
                            {cv::IMWRITE_JPEG_QUALITY, 95, cv::IMWRITE_JPEG_RST_INTERVAL, 1});
  std::size_t stuffed = 0;
  for (std::size_t i = segment_at(jpeg, 0xDA); i + 1 < jpeg.size(); ++i)
    stuffed += jpeg[i] == 0xFF && jpeg[i + 1] == 0x00;
  ASSERT_GT(stuffed, 0u);
  const JpegHeader h = inspected(jpeg);
  EXPECT_EQ(h.scans, 1u);
  EXPECT_EQ(h.restart_markers, 4u * 3u - 1u);
}

TEST(InspectJpeg, CountsScansAfterTheFirstScansData) {
  EXPECT_EQ(inspected(with_repeated_scan(colour_jpeg(), 4)).scans, 5u);
}

TEST(InspectJpeg, NamesWhatIsWrongWithBrokenStreams) {
  const Bytes jpeg = colour_jpeg();
  expect_mentions(inspect_jpeg({}).error, "not a JPEG");
  expect_mentions(inspect_jpeg(test::random_bytes(500, 4)).error, "not a JPEG");
  expect_mentions(inspect_jpeg(Bytes(jpeg.begin(), jpeg.end() - 40)).error, "truncated JPEG");
  Bytes trailing = jpeg;
  trailing.push_back(0);
  expect_mentions(inspect_jpeg(trailing).error, "1 bytes after the end-of-image marker");
  Bytes no_scan(jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(segment_at(jpeg, 0xDA)));
  no_scan.insert(no_scan.end(), {0xFF, 0xD9});
  expect_mentions(inspect_jpeg(no_scan).error, "no scan");
  Bytes zero_height = test::with_sof_size(jpeg, 64, 0);
  expect_mentions(inspect_jpeg(zero_height).error, "frame size 64x0");
  Bytes two_frames = jpeg;
  const std::size_t sof = segment_at(jpeg, 0xC0);
  const std::size_t sof_end = sof + 2 + ((std::size_t{jpeg[sof + 2]} << 8) | jpeg[sof + 3]);
  two_frames.insert(two_frames.begin() + static_cast<std::ptrdiff_t>(sof_end),
                    jpeg.begin() + static_cast<std::ptrdiff_t>(sof),
                    jpeg.begin() + static_cast<std::ptrdiff_t>(sof_end));
  expect_mentions(inspect_jpeg(two_frames).error, "second start-of-frame");
}

TEST(InspectJpeg, NeverReadsPastTheEndOfRandomBytesAfterAStartOfImage) {
  for (unsigned seed = 1; seed <= 200; ++seed) {
    Bytes bytes = test::random_bytes(256, seed);
    bytes[0] = 0xFF;
    bytes[1] = 0xD8;
    EXPECT_FALSE(inspect_jpeg(bytes).ok()) << seed;
  }
  const Bytes jpeg = colour_jpeg();
  for (std::size_t cut = 0; cut < jpeg.size(); ++cut)
    EXPECT_FALSE(
        inspect_jpeg(Bytes(jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(cut))).ok())
        << "cut at " << cut;
}

TEST(JpegCost, DefaultLimitsTakeAnOrdinaryKeyframe) {
  const Bytes jpeg = colour_jpeg(640, 480);
  EXPECT_EQ(find_jpeg_cost_problem(inspected(jpeg), jpeg.size(), StationLimits{}), std::nullopt);
}

TEST(JpegCost, DefaultRatioTakesFlatImages) {
  // The most compressible ordinary content: one colour. Well under max_pixels_per_byte.
  for (const cv::Mat& flat : {cv::Mat(3072, 4096, CV_8UC3, cv::Scalar(40, 120, 200)),
                              cv::Mat(3072, 4096, CV_8UC1, cv::Scalar(0))}) {
    const Bytes jpeg = encode(flat);
    const double per_byte = 4096.0 * 3072.0 / static_cast<double>(jpeg.size());
    EXPECT_LT(per_byte, StationLimits{}.max_pixels_per_byte / 2) << jpeg.size() << " bytes";
    EXPECT_EQ(find_jpeg_cost_problem(inspected(jpeg), jpeg.size(), StationLimits{}), std::nullopt);
  }
}

TEST(JpegCost, RefusesCodingProcessesTheStationDoesNotDecodeCheaply) {
  const Bytes jpeg = colour_jpeg();
  const std::size_t sof = segment_at(jpeg, 0xC0);
  const std::pair<std::uint8_t, const char*> refused[] = {
      {0xC3, "lossless"}, {0xC5, "hierarchical"}, {0xC9, "arithmetic"}, {0xCA, "arithmetic"}};
  for (const auto& [marker, name] : refused) {
    Bytes edited = jpeg;
    edited[sof + 1] = marker;
    const std::string reason = cost_problem(edited);
    expect_mentions(reason, name);
    expect_mentions(reason, "baseline, extended sequential or progressive");
  }
  Bytes extended = jpeg;
  extended[sof + 1] = 0xC1;
  EXPECT_EQ(find_jpeg_cost_problem(inspected(extended), extended.size(), StationLimits{}),
            std::nullopt);
}

TEST(JpegCost, RefusesOtherThanEightBitSamples) {
  Bytes jpeg = colour_jpeg();
  jpeg[segment_at(jpeg, 0xC0) + 4] = 12;
  expect_mentions(cost_problem(jpeg), "precision 12 bits");
}

TEST(JpegCost, RefusesTwoComponents) {
  Bytes jpeg = colour_jpeg();
  const std::size_t sof = segment_at(jpeg, 0xC0);
  jpeg[sof + 3] = 8 + 3 * 2;  // segment length
  jpeg[sof + 9] = 2;          // components
  jpeg.erase(jpeg.begin() + static_cast<std::ptrdiff_t>(sof + 2 + 8 + 3 * 2),
             jpeg.begin() + static_cast<std::ptrdiff_t>(sof + 2 + 8 + 3 * 3));
  expect_mentions(cost_problem(jpeg), "2 components");
}

TEST(JpegCost, RefusesInvalidSamplingFactors) {
  Bytes jpeg = colour_jpeg();
  const std::size_t first = segment_at(jpeg, 0xC0) + 2 + 8 + 1;  // component 1's sampling
  Bytes zero = jpeg;
  zero[first] = 0x50;
  expect_mentions(cost_problem(zero), "sampling 5x0");
  Bytes huge_mcu = jpeg;
  for (int c = 0; c < 3; ++c) huge_mcu[first + 3 * c] = 0x44;
  expect_mentions(cost_problem(huge_mcu), "48 blocks per MCU");
}

TEST(JpegCost, RefusesDimensionsAndPixelsBeyondTheLimits) {
  const Bytes jpeg = colour_jpeg(640, 480);
  StationLimits limits;
  limits.max_width = 639;
  std::string reason = cost_problem(jpeg, limits);
  expect_mentions(reason, "640x480");
  expect_mentions(reason, "max_width x max_height 639x4096");

  limits = {};
  limits.max_pixels = 640 * 480 - 1;
  reason = cost_problem(jpeg, limits);
  expect_mentions(reason, "307200 pixels");
  expect_mentions(reason, "max_pixels 307199");

  // A header edited to claim more than the defaults allow, whatever the data.
  expect_mentions(cost_problem(test::with_sof_size(jpeg, 4096, 4096)), "max_pixels 12582912");
}

TEST(JpegCost, RefusesMoreScansThanTheBound) {
  const Bytes progressive =
      encode(test::make_smooth_image(64, 48), {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  const std::uint32_t scans = inspected(progressive).scans;
  StationLimits limits;
  limits.max_scans = static_cast<int>(scans) - 1;
  const std::string reason = cost_problem(progressive, limits);
  expect_mentions(reason, "progressive");
  expect_mentions(reason, std::to_string(scans) + " scans");
  expect_mentions(reason, "max_scans " + std::to_string(scans - 1));

  // Many scans in a small sample: each one is another pass of the decoder.
  expect_mentions(cost_problem(with_repeated_scan(colour_jpeg(), 40)), "41 scans");
}

TEST(JpegCost, RefusesMorePixelsPerCompressedByteThanTheBound) {
  const Bytes jpeg = colour_jpeg(640, 480);
  StationLimits limits;
  limits.max_pixels_per_byte = 2;
  const std::string reason = cost_problem(jpeg, limits);
  expect_mentions(reason, "307200 pixels in " + std::to_string(jpeg.size()) + " bytes");
  expect_mentions(reason, "max_pixels_per_byte 2");
  // The same small stream claiming a large frame: a decompression bomb by the default ratio.
  const Bytes bomb = test::with_sof_size(colour_jpeg(64, 48), 4000, 3000);
  expect_mentions(cost_problem(bomb), "pixels per byte");
}

TEST(JpegDimensions, StopsAtTheFrameHeader) {
  const Bytes jpeg = colour_jpeg(64, 48);
  const Bytes header_only(jpeg.begin(),
                          jpeg.begin() + static_cast<std::ptrdiff_t>(segment_at(jpeg, 0xDA)));
  const auto size = jpeg_dimensions(header_only);
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, 64u);
  EXPECT_EQ(size->height, 48u);
}

}  // namespace
}  // namespace keyfleet
