// decode_jpeg_bgr / encode_jpeg_bgr against OpenCV's own JPEG codec: the same pixels and
// bytes, and no crash on what OpenCV would refuse.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <vector>

#include "keyfleet/common/jpeg_turbo.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

// Smooth gradients, sharp shapes and noise: every kind of 8x8 block.
cv::Mat make_scene(int width, int height) {
  cv::Mat image = test::make_smooth_image(width, height);
  cv::rectangle(image, {width / 5, height / 4, width / 3, height / 3}, {20, 200, 240}, cv::FILLED);
  cv::putText(image, "CAFE", {width / 2, height * 3 / 4}, cv::FONT_HERSHEY_DUPLEX, 2.0,
              {10, 10, 10}, 3);
  cv::Mat noise(image.size(), CV_8UC3);
  cv::randu(noise, 0, 24);
  return image + noise;
}

std::vector<std::uint8_t> opencv_jpeg(const cv::Mat& image, std::vector<int> params) {
  std::vector<std::uint8_t> bytes;
  cv::imencode(".jpg", image, bytes, params);
  return bytes;
}

void expect_decodes_as_opencv(const std::vector<std::uint8_t>& bytes) {
  cv::Mat ours;
  ASSERT_TRUE(decode_jpeg_bgr(bytes.data(), bytes.size(), ours));
  const cv::Mat theirs = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(ours.size(), theirs.size());
  ASSERT_EQ(ours.type(), theirs.type());
  EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0);
}

TEST(JpegTurbo, DecodesTheSamePixelsAsOpenCV) {
  const cv::Mat scene = make_scene(640, 480);
  expect_decodes_as_opencv(opencv_jpeg(scene, {cv::IMWRITE_JPEG_QUALITY, 92}));
  expect_decodes_as_opencv(opencv_jpeg(scene, {cv::IMWRITE_JPEG_QUALITY, 40}));
  expect_decodes_as_opencv(opencv_jpeg(scene, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  expect_decodes_as_opencv(
      opencv_jpeg(scene, {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, 4}));
  expect_decodes_as_opencv(opencv_jpeg(make_scene(333, 111), {}));  // not a multiple of 16
  cv::Mat grey;
  cv::cvtColor(scene, grey, cv::COLOR_BGR2GRAY);
  expect_decodes_as_opencv(opencv_jpeg(grey, {}));  // one channel, read as BGR
}

// OpenCV's IMREAD_REDUCED_COLOR_N asks libjpeg for the same DCT scaling: the same pixels.
TEST(JpegTurbo, DecodesAtAHalfQuarterAndEighthAsOpenCVsReducedRead) {
  const cv::Mat scene = make_scene(640, 480);
  const auto bytes = opencv_jpeg(scene, {cv::IMWRITE_JPEG_QUALITY, 92});
  const std::pair<int, int> flags[] = {{2, cv::IMREAD_REDUCED_COLOR_2},
                                       {4, cv::IMREAD_REDUCED_COLOR_4},
                                       {8, cv::IMREAD_REDUCED_COLOR_8}};
  for (const auto& [reduce, flag] : flags) {
    cv::Mat ours;
    cv::Size full;
    ASSERT_TRUE(decode_jpeg_bgr(bytes.data(), bytes.size(), ours, reduce, &full)) << reduce;
    EXPECT_EQ(full, cv::Size(640, 480));
    EXPECT_EQ(ours.size(), cv::Size(640 / reduce, 480 / reduce));
    const cv::Mat theirs = cv::imdecode(bytes, flag);
    ASSERT_EQ(ours.size(), theirs.size());
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0) << reduce;
    // And close to an area resize of the whole decode: the same picture, not the same pixels.
    cv::Mat area;
    cv::resize(cv::imdecode(bytes, cv::IMREAD_COLOR), area, ours.size(), 0, 0, cv::INTER_AREA);
    EXPECT_LT(cv::norm(ours, area, cv::NORM_L1) / double(area.total() * 3), 4.0) << reduce;
  }
  cv::Mat odd;  // each side rounded up
  const auto odd_bytes = opencv_jpeg(make_scene(333, 111), {});
  ASSERT_TRUE(decode_jpeg_bgr(odd_bytes.data(), odd_bytes.size(), odd, 2));
  EXPECT_EQ(odd.size(), cv::Size(167, 56));
  EXPECT_FALSE(decode_jpeg_bgr(bytes.data(), bytes.size(), odd, 3));  // not a DCT scale
  EXPECT_FALSE(decode_jpeg_bgr(bytes.data(), bytes.size(), odd, 0));
}

TEST(JpegTurbo, ReusesTheBufferOfAnUnsharedImageOfTheSameSize) {
  const auto bytes = opencv_jpeg(make_scene(320, 240), {});
  cv::Mat image;
  ASSERT_TRUE(decode_jpeg_bgr(bytes.data(), bytes.size(), image));
  const std::uint8_t* buffer = image.data;
  ASSERT_TRUE(decode_jpeg_bgr(bytes.data(), bytes.size(), image));
  EXPECT_EQ(image.data, buffer);
}

TEST(JpegTurbo, RefusesWhatItCannotDecodeWithoutThrowing) {
  cv::Mat image;
  const std::vector<std::uint8_t> empty;
  EXPECT_FALSE(decode_jpeg_bgr(empty.data(), 0, image));
  const auto png = [] {
    std::vector<std::uint8_t> bytes;
    cv::imencode(".png", make_scene(64, 48), bytes);
    return bytes;
  }();
  EXPECT_FALSE(decode_jpeg_bgr(png.data(), png.size(), image));
  const auto noise = test::random_bytes(5000, 3);
  EXPECT_FALSE(decode_jpeg_bgr(noise.data(), noise.size(), image));
  auto jpeg = opencv_jpeg(make_scene(640, 480), {});
  jpeg.resize(300);  // the header and nothing else: libjpeg gives up, no exception
  EXPECT_NO_THROW(decode_jpeg_bgr(jpeg.data(), jpeg.size(), image));
}

TEST(JpegTurbo, LeavesExifFilesToOpenCV) {  // cv::imread turns them by their orientation tag
  auto jpeg = opencv_jpeg(make_scene(64, 48), {});
  const std::vector<std::uint8_t> exif = {0xFF, 0xE1, 0x00, 0x08, 'E', 'x', 'i', 'f', 0, 0};
  jpeg.insert(jpeg.begin() + 2, exif.begin(), exif.end());
  cv::Mat image;
  EXPECT_FALSE(decode_jpeg_bgr(jpeg.data(), jpeg.size(), image));
}

TEST(JpegTurbo, EncodesTheSameBytesAsOpenCV) {
  const cv::Mat scene = make_scene(640, 480);
  for (const int quality : {1, 50, 85, 100}) {
    std::vector<std::uint8_t> ours;
    ASSERT_TRUE(encode_jpeg_bgr(scene, quality, ours));
    EXPECT_EQ(ours, opencv_jpeg(scene, {cv::IMWRITE_JPEG_QUALITY, quality})) << quality;
  }
  std::vector<std::uint8_t> ours;  // a view into a larger image: rows with a stride
  ASSERT_TRUE(encode_jpeg_bgr(scene(cv::Rect(10, 20, 300, 200)), 85, ours));
  EXPECT_EQ(ours, opencv_jpeg(scene(cv::Rect(10, 20, 300, 200)), {cv::IMWRITE_JPEG_QUALITY, 85}));
  EXPECT_FALSE(encode_jpeg_bgr(cv::Mat(8, 8, CV_8UC1), 85, ours));
}

TEST(JpegTurbo, ReadsFilesAsImreadDoes) {
  const auto folder = std::filesystem::temp_directory_path() / "keyfleet_jpeg_turbo_test";
  std::filesystem::create_directories(folder);
  const cv::Mat scene = make_scene(160, 120);
  std::vector<std::uint8_t> buffer;
  for (const char* name : {"frame.jpg", "frame.png"}) {
    const std::string path = (folder / name).string();
    ASSERT_TRUE(cv::imwrite(path, scene));
    const cv::Mat ours = read_image_bgr(path, buffer);
    const cv::Mat theirs = cv::imread(path, cv::IMREAD_COLOR);
    ASSERT_EQ(ours.size(), theirs.size()) << name;
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0) << name;
  }
  // Reduced: a JPEG at half size with its own size reported, a PNG whole.
  cv::Size full;
  EXPECT_EQ(read_image_bgr((folder / "frame.jpg").string(), buffer, 2, &full).size(),
            cv::Size(80, 60));
  EXPECT_EQ(full, cv::Size(160, 120));
  EXPECT_EQ(read_image_bgr((folder / "frame.png").string(), buffer, 2, &full).size(),
            cv::Size(160, 120));
  EXPECT_EQ(full, cv::Size(160, 120));
  EXPECT_TRUE(read_image_bgr((folder / "missing.jpg").string(), buffer).empty());
  std::ofstream((folder / "bad.jpg").string()) << "not an image";
  EXPECT_TRUE(read_image_bgr((folder / "bad.jpg").string(), buffer).empty());
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace keyfleet
