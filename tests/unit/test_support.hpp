#pragma once
// Helpers shared by the unit tests: scratch directories, synthetic images and keyframes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::test {

// The shared real-data folder (KEYFLEET_DATA, set by ctest; default ../shared/data).
inline std::filesystem::path data_dir() {
  const char* env = std::getenv("KEYFLEET_DATA");
  return env ? std::filesystem::path(env) : std::filesystem::path("../shared/data");
}

// Declares `data_path` = data_dir() / relative, or skips the test saying where it looked.
#define KEYFLEET_REQUIRE_DATA(relative)                                              \
  const std::filesystem::path data_path = ::keyfleet::test::data_dir() / (relative); \
  if (!std::filesystem::exists(data_path))                                           \
  GTEST_SKIP() << "real data not found at " << data_path                             \
               << " (set KEYFLEET_DATA to the shared data folder to run this test)"

// A fresh directory under the system temp dir, named after the running test, removed
// (with its contents) when the object goes out of scope.
class TempDir {
 public:
  TempDir() {
    std::string name = "keyfleet_unit";
    if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info()) {
      name += std::string("_") + info->test_suite_name() + "_" + info->name();
    }
    for (char& c : name) {
      if (c == '/' || c == '\\') c = '_';
    }
    std::random_device entropy;
    const auto base = std::filesystem::temp_directory_path();
    for (int attempt = 0; attempt < 100; ++attempt) {
      const auto candidate =
          base / (name + "_" + std::to_string(::getpid()) + "_" + std::to_string(entropy()));
      if (std::filesystem::create_directory(candidate)) {
        path_ = candidate;
        return;
      }
    }
    throw std::runtime_error("could not create a unique temporary directory");
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A smooth BGR scene (gradients and shapes) that JPEG reproduces closely.
inline cv::Mat make_smooth_image(int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(
          static_cast<std::uint8_t>(255 * x / width), static_cast<std::uint8_t>(255 * y / height),
          static_cast<std::uint8_t>(255 * (x + y) / (width + height)));
    }
  }
  cv::rectangle(image, cv::Rect(width / 8, height / 8, width / 4, height / 4),
                cv::Scalar(30, 200, 60), cv::FILLED);
  cv::circle(image, cv::Point(3 * width / 4, height / 2), std::min(width, height) / 6,
             cv::Scalar(220, 40, 180), cv::FILLED);
  return image;
}

// Uniform noise: large JPEGs whose scan data dominates the file.
inline cv::Mat make_noise_image(int width, int height, unsigned seed) {
  cv::Mat image(height, width, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  return image;
}

inline std::vector<std::uint8_t> random_bytes(std::size_t count, unsigned seed) {
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<std::uint8_t> bytes(count);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(byte(generator));
  return bytes;
}

// Offset of the first SOFn marker (FF Cn, not DHT/JPG/DAC) in a JPEG, found independently
// of the library's parser so that tests can edit the header.
inline std::optional<std::size_t> find_sof_marker(const std::vector<std::uint8_t>& jpeg) {
  std::size_t pos = 2;
  while (pos + 4 <= jpeg.size() && jpeg[pos] == 0xFF) {
    const std::uint8_t marker = jpeg[pos + 1];
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC)
      return pos;
    const std::size_t length = (std::size_t{jpeg[pos + 2]} << 8) | jpeg[pos + 3];
    pos += 2 + length;
  }
  return std::nullopt;
}

// Rewrites the frame size in the SOF header; the rest of the file is unchanged.
inline std::vector<std::uint8_t> with_sof_size(std::vector<std::uint8_t> jpeg, std::uint16_t width,
                                               std::uint16_t height) {
  const auto sof = find_sof_marker(jpeg);
  if (!sof) throw std::runtime_error("test JPEG has no SOF marker");
  jpeg[*sof + 5] = static_cast<std::uint8_t>(height >> 8);
  jpeg[*sof + 6] = static_cast<std::uint8_t>(height & 0xFF);
  jpeg[*sof + 7] = static_cast<std::uint8_t>(width >> 8);
  jpeg[*sof + 8] = static_cast<std::uint8_t>(width & 0xFF);
  return jpeg;
}

inline std::vector<std::uint8_t> encode_jpeg(const cv::Mat& image, int quality = 85) {
  return JpegCodec(quality).encode(image);
}

// A keyframe that a station with default limits accepts: a real JPEG, correct claims.
inline Keyframe make_valid_keyframe(const std::string& robot_id, std::uint64_t sequence,
                                    int width = 64, int height = 48) {
  Keyframe k;
  k.robot_id = robot_id;
  k.sequence_number = sequence;
  k.frame_index = 100 + sequence * 15;
  k.capture_time_ns = 1'700'000'000'000'000'000LL + static_cast<std::int64_t>(sequence) * 500;
  k.vslam_keyframe_index = sequence;
  k.window_first_frame = k.frame_index - 7;
  k.window_last_frame = k.frame_index + 7;
  k.quality_score = 0.75;
  k.sharpness_score = 123.5;
  k.semantic_score = 0.25;
  k.encoding = "jpeg";
  k.width = static_cast<std::uint32_t>(width);
  k.height = static_cast<std::uint32_t>(height);
  k.image = encode_jpeg(make_smooth_image(width, height));
  k.camera_pose = Pose{1.5, -2.25, 3.0, 0.0, 0.0, 0.70710678, 0.70710678};
  return k;
}

}  // namespace keyfleet::test
