// The plugins that carry OpenCV's image and video files (keyfleet/common/opencv_io.hpp): loaded
// from the build, the same pixels and bytes as OpenCV's own calls, a clear error naming every
// place where one cannot be loaded, and no robot agent that loads OpenCV's codecs at its start.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"
#include "keyfleet/common/opencv_io.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

cv::Mat scene() {
  cv::Mat image = test::make_smooth_image(96, 64);
  cv::putText(image, "KF", {20, 44}, cv::FONT_HERSHEY_DUPLEX, 1.2, {10, 10, 200}, 2);
  return image;
}

TEST(OpenCvIo, DecodesAndEncodesAsOpenCvDoes) {
  const cv::Mat image = scene();
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(image_files().encode(".png", image, {}, png));
  std::vector<std::uint8_t> theirs;
  ASSERT_TRUE(cv::imencode(".png", image, theirs));
  EXPECT_EQ(png, theirs);
  const cv::Mat decoded = image_files().decode(png, cv::IMREAD_COLOR);
  ASSERT_EQ(decoded.size(), image.size());
  EXPECT_EQ(cv::norm(decoded, image, cv::NORM_INF), 0);
  EXPECT_TRUE(image_files().decode({1, 2, 3, 4}, cv::IMREAD_COLOR).empty());
  std::vector<std::uint8_t> none;
  EXPECT_FALSE(image_files().encode(".no-such-format", image, {}, none));
}

TEST(OpenCvIo, ReadsNonJpegFilesThroughThePlugin) {
  test::TempDir dir;
  const std::string path = (dir.path() / "frame.png").string();
  ASSERT_TRUE(cv::imwrite(path, scene()));
  std::vector<std::uint8_t> bytes;
  const cv::Mat read = read_image_bgr(path, bytes);
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(cv::norm(read, cv::imread(path, cv::IMREAD_COLOR), cv::NORM_INF), 0);
}

TEST(OpenCvIo, ReadsAVideoFileFrameByFrame) {
  test::TempDir dir;
  const std::string path = (dir.path() / "clip.avi").string();
  {
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 12, {96, 64});
    if (!writer.isOpened()) GTEST_SKIP() << "this OpenCV cannot write MJPEG .avi";
    for (int i = 0; i < 5; ++i) writer.write(scene());
  }
  const std::unique_ptr<VideoReader> video = video_files().open(path);
  ASSERT_NE(video, nullptr);
  EXPECT_DOUBLE_EQ(video->fps(), 12);
  cv::Mat frame;
  int frames = 0;
  while (video->read(frame)) {
    EXPECT_EQ(frame.size(), cv::Size(96, 64));
    ++frames;
  }
  EXPECT_EQ(frames, 5);
  EXPECT_EQ(video_files().open((dir.path() / "missing.avi").string()), nullptr);
}

TEST(OpenCvIo, SaysWhereItLookedWhenAPluginCannotBeLoaded) {
  test::TempDir dir;
  const std::string absent = (dir.path() / "absent" / kImagesPlugin.file).string();
  const std::string not_a_library = (dir.path() / "text.so").string();
  std::ofstream(not_a_library) << "not a shared object\n";
  // A shared object without the entry: the other plugin.
  const std::vector<std::string> video_plugin = plugin_places(kVideoPlugin);
  ASSERT_FALSE(video_plugin.empty());
  try {
    load_plugin(kImagesPlugin, {absent, not_a_library, video_plugin.back()});
    FAIL() << "loaded a plugin from none";
  } catch (const StartupError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(kImagesPlugin.file), std::string::npos) << what;
    EXPECT_NE(what.find(absent + ": not there"), std::string::npos) << what;
    EXPECT_NE(what.find(not_a_library + ": "), std::string::npos) << what;
    EXPECT_NE(what.find(video_plugin.back() + ": no " + kImagesPlugin.entry), std::string::npos)
        << what;
  }
  // Where it is, it loads.
  EXPECT_NE(load_plugin(kVideoPlugin, {absent, video_plugin.back()}), nullptr);
}

TEST(OpenCvIo, LooksInThePluginDirFirstAndInEachPlaceOnce) {
  ::setenv("KEYFLEET_PLUGIN_DIR", "/opt/elsewhere/", 1);
  const std::vector<std::string> places = plugin_places(kImagesPlugin);
  ::unsetenv("KEYFLEET_PLUGIN_DIR");
  ASSERT_GE(places.size(), 2u);
  EXPECT_EQ(places.front(), std::string("/opt/elsewhere/") + kImagesPlugin.file);
  for (std::size_t i = 0; i < places.size(); ++i)
    for (std::size_t j = i + 1; j < places.size(); ++j) EXPECT_NE(places[i], places[j]);
}

// The agent's start: Debian's imgcodecs and videoio bring about 220 shared libraries that an
// agent on JPEG frames never needs (docs/results/2026-11-29-agent-start.md).
TEST(OpenCvIo, TheRobotAgentDoesNotLinkOpenCvsCodecs) {
  const std::string agent = KEYFLEET_ROBOT_AGENT;
  std::FILE* ldd = ::popen(("ldd '" + agent + "' 2>&1").c_str(), "r");
  ASSERT_NE(ldd, nullptr);
  std::string listing;
  char line[512];
  while (std::fgets(line, sizeof line, ldd)) listing += line;
  ASSERT_EQ(::pclose(ldd), 0) << listing;
  EXPECT_NE(listing.find("libopencv_core"), std::string::npos) << listing;
  EXPECT_EQ(listing.find("libopencv_imgcodecs"), std::string::npos) << listing;
  EXPECT_EQ(listing.find("libopencv_videoio"), std::string::npos) << listing;
}

}  // namespace
}  // namespace keyfleet
