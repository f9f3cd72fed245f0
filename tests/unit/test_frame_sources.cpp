// Frame sources: real recordings from KEYFLEET_DATA (skipped when absent), bad files
// skipped with an error, and the generated flight deterministic from its seed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/error.hpp"
#include "test_support.hpp"

namespace keyfleet::agent {
namespace {

namespace fs = std::filesystem;

std::vector<Frame> read_all(FrameSource& source) {
  std::vector<Frame> frames;
  while (auto frame = source.next()) frames.push_back(*frame);
  return frames;
}

TEST(ImageFolderSource, ReplaysARealKittiSequenceInOrderWithStreamTimestamps) {
  KEYFLEET_REQUIRE_DATA("kitti/KITTI_sequence_1/image_l");
  SourceConfig config;
  config.kind = SourceConfig::Kind::kImageFolder;
  config.path = data_path.string();
  config.fps = 10;
  auto source = make_frame_source(config, null_logger());
  const auto frames = read_all(*source);
  ASSERT_EQ(frames.size(), 51u);
  EXPECT_EQ(frames[0].image.cols, 1226);
  EXPECT_EQ(frames[0].image.rows, 370);
  EXPECT_EQ(frames[0].image.type(), CV_8UC3);
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].index, i);
  EXPECT_EQ(frames[10].capture_time_ns, 1'000'000'000);
  const cv::Mat first = cv::imread((data_path / "000000.png").string(), cv::IMREAD_COLOR);
  EXPECT_EQ(cv::norm(first, frames[0].image, cv::NORM_INF), 0.0);
}

TEST(ImageFolderSource, MaxFramesStopsEarly) {
  KEYFLEET_REQUIRE_DATA("kitti/KITTI_sequence_2/image_l");
  SourceConfig config;
  config.kind = SourceConfig::Kind::kImageFolder;
  config.path = data_path.string();
  config.max_frames = 7;
  auto source = make_frame_source(config, null_logger());
  EXPECT_EQ(read_all(*source).size(), 7u);
}

TEST(ImageFolderSource, UnreadableImageIsSkippedAndTheRestStreams) {
  test::TempDir dir;
  for (int i = 0; i < 3; ++i)
    cv::imwrite((dir.path() / ("f" + std::to_string(i) + ".png")).string(),
                cv::Mat(32, 48, CV_8UC3, cv::Scalar(i * 40, 10, 10)));
  std::ofstream(dir.path() / "f1b.png") << "this is not a PNG";
  SourceConfig config;
  config.kind = SourceConfig::Kind::kImageFolder;
  config.path = dir.path().string();
  auto source = make_frame_source(config, null_logger());
  const auto frames = read_all(*source);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[2].index, 2u);  // indices stay contiguous over the skipped file
}

// selector.decode_reduce: JPEGs at half size for the selection, every pixel back on demand;
// other formats whole.
TEST(ImageFolderSource, DecodesJpegsReducedAndGivesTheWholeFrameBackOnDemand) {
  test::TempDir dir;
  const cv::Mat scene = test::make_smooth_image(320, 240);
  ASSERT_TRUE(cv::imwrite((dir.path() / "a.jpg").string(), scene));
  ASSERT_TRUE(cv::imwrite((dir.path() / "b.png").string(), scene));
  SourceConfig config;
  config.kind = SourceConfig::Kind::kImageFolder;
  config.path = dir.path().string();
  auto source = make_frame_source(config, null_logger(), 2);
  const auto frames = read_all(*source);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].image.size(), cv::Size(160, 120));
  EXPECT_EQ(frame_size(frames[0]), cv::Size(320, 240));
  ASSERT_TRUE(frames[0].encoded);
  const cv::Mat whole = full_image(frames[0]);
  const cv::Mat read = cv::imread((dir.path() / "a.jpg").string(), cv::IMREAD_COLOR);
  ASSERT_EQ(whole.size(), read.size());
  EXPECT_EQ(cv::norm(whole, read, cv::NORM_INF), 0.0);
  EXPECT_EQ(frames[1].image.size(), cv::Size(320, 240));  // the PNG: whole, nothing kept
  EXPECT_EQ(frame_size(frames[1]), cv::Size(320, 240));
  EXPECT_FALSE(frames[1].encoded);
  EXPECT_EQ(full_image(frames[1]).data, frames[1].image.data);
}

TEST(ImageFolderSource, MissingOrEmptyFolderIsAStartupErrorNamingIt) {
  SourceConfig config;
  config.kind = SourceConfig::Kind::kImageFolder;
  config.path = "/nonexistent/frames";
  try {
    make_frame_source(config, null_logger());
    FAIL() << "expected StartupError";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/frames"), std::string::npos);
  }
  test::TempDir empty;
  config.path = empty.path().string();
  EXPECT_THROW(make_frame_source(config, null_logger()), StartupError);
}

TEST(VideoFileSource, ReadsARealHandHeldVideoWithItsOwnFrameRate) {
  KEYFLEET_REQUIRE_DATA("opencv_samples/video/box.mp4");
  SourceConfig config;
  config.kind = SourceConfig::Kind::kVideoFile;
  config.path = data_path.string();
  config.max_frames = 20;
  auto source = make_frame_source(config, null_logger());
  const auto frames = read_all(*source);
  ASSERT_EQ(frames.size(), 20u);
  EXPECT_EQ(frames[0].image.cols, 640);
  EXPECT_EQ(frames[0].image.rows, 480);
  EXPECT_GT(source->fps(), 0.0);
  EXPECT_GT(cv::norm(frames[0].image, frames[19].image, cv::NORM_L1), 0.0) << "camera moves";
}

TEST(VideoFileSource, NotAVideoIsAStartupError) {
  test::TempDir dir;
  const fs::path fake = dir.path() / "fake.mp4";
  std::ofstream(fake) << "not a video";
  SourceConfig config;
  config.kind = SourceConfig::Kind::kVideoFile;
  config.path = fake.string();
  EXPECT_THROW(make_frame_source(config, null_logger()), StartupError);
}

TEST(GeneratedSource, SameSeedSameBytesOtherSeedOtherFlight) {
  SourceConfig config;
  config.max_frames = 5;
  config.width = 160;
  config.height = 120;
  auto a = read_all(*make_generated_source(config));
  auto b = read_all(*make_generated_source(config));
  config.seed = 2;
  auto c = read_all(*make_generated_source(config));
  ASSERT_EQ(a.size(), 5u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(cv::norm(a[i].image, b[i].image, cv::NORM_INF), 0.0) << "frame " << i;
    EXPECT_EQ(a[i].image.size(), cv::Size(160, 120));
  }
  EXPECT_GT(cv::norm(a[0].image, c[0].image, cv::NORM_L1), 0.0);
}

TEST(GeneratedSource, ZeroMaxFramesFliesUntilStopped) {
  SourceConfig config;
  config.max_frames = 0;
  config.width = 64;
  config.height = 48;
  auto source = make_generated_source(config);
  for (int i = 0; i < 2000; ++i) ASSERT_TRUE(source->next().has_value()) << i;
}

}  // namespace
}  // namespace keyfleet::agent
