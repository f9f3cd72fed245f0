// V-SLAM keyframe triggers: the ORB-SLAM2 emulation fires on a moving camera and stays quiet
// on a static one, the grid ORB extractor spreads its features, and the keyframe list reader
// matches timestamps within half a frame period and names the bad line of a broken file.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/agent/grid_orb_extractor.hpp"
#include "keyfleet/agent/keyframe_trigger.hpp"
#include "keyfleet/common/config.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "test_support.hpp"

namespace keyfleet::agent {
namespace {

namespace fs = std::filesystem;

constexpr double kFps = 30;

Frame make_frame(std::uint64_t index, const cv::Mat& image) {
  Frame frame;
  frame.index = index;
  frame.capture_time_ns = std::int64_t(std::llround(double(index) * 1e9 / kFps));
  frame.image = image;
  return frame;
}

OrbSlamTriggerParams default_trigger_params() {
  OrbSlamTriggerParams params;
  params.max_frames = 30;
  return params;
}

// Indices of the frames on which the trigger fires.
std::vector<std::uint64_t> fired_on(KeyframeTrigger& trigger, const std::vector<Frame>& frames) {
  std::vector<std::uint64_t> fired;
  for (const auto& frame : frames)
    if (trigger.is_keyframe(frame)) fired.push_back(frame.index);
  return fired;
}

std::string join(const std::vector<std::uint64_t>& values) {
  std::ostringstream out;
  for (std::size_t i = 0; i < values.size(); ++i) out << (i ? " " : "") << values[i];
  return out.str();
}

// What a moving camera must give: the first frame starts the map, more keyframes follow all
// along the flight, and never on two frames in a row (local mapping is busy after one).
void expect_fires_repeatedly(const std::vector<std::uint64_t>& fired, std::size_t frames) {
  ASSERT_FALSE(fired.empty());
  EXPECT_EQ(fired.front(), 0u) << "the first frame starts the map";
  EXPECT_GE(fired.size(), 4u) << "keyframes on " << join(fired);
  EXPECT_GE(fired.back(), frames - 30) << "no keyframe late in the sequence: " << join(fired);
  for (std::size_t i = 1; i < fired.size(); ++i)
    EXPECT_GT(fired[i] - fired[i - 1], 1u) << "consecutive keyframes: " << join(fired);
}

// One drone of a small generated street, flown sideways past the facades.
class GeneratedFlight : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    ScenarioConfig config;
    config.seed = 5;
    config.frames_per_drone = 90;
    config.width = 320;
    config.height = 240;
    config.street.length_m = 60;
    config.drones.count = 1;
    config.drones.shake_burst_rate_hz = 0.5;
    scenario::generate_scenario(config, dir_->file("street"), null_logger());
    const auto s = scenario::read_scenario(dir_->file("street"));
    const fs::path drone = dir_->path() / "street" / s.drones.at(0).folder;
    frames_ = new std::vector<Frame>();
    for (const auto& truth : scenario::read_frame_truth(drone.string()))
      frames_->push_back(
          make_frame(truth.index, cv::imread((drone / truth.image).string(), cv::IMREAD_COLOR)));
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete dir_;
  }
  static test::TempDir* dir_;
  static std::vector<Frame>* frames_;
};
test::TempDir* GeneratedFlight::dir_ = nullptr;
std::vector<Frame>* GeneratedFlight::frames_ = nullptr;

// --- OrbSlamTrigger ----------------------------------------------------------------------------

TEST_F(GeneratedFlight, OrbSlamTriggerFiresRepeatedlyOnAMovingCamera) {
  ASSERT_EQ(frames_->size(), 90u);
  ASSERT_FALSE(frames_->front().image.empty());
  OrbSlamTrigger trigger(default_trigger_params());
  expect_fires_repeatedly(fired_on(trigger, *frames_), frames_->size());
}

TEST_F(GeneratedFlight, OrbSlamTriggerNeverFiresAgainOnAStaticNoisyCamera) {
  // The same view 60 times, each copy with its own sensor noise: a real camera standing still.
  const cv::Mat view = frames_->front().image;
  OrbSlamTrigger trigger(default_trigger_params());
  cv::RNG rng(7);
  for (std::uint64_t i = 0; i < 60; ++i) {
    cv::Mat noise(view.size(), CV_16SC3), image;
    rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
    view.convertTo(image, CV_16SC3);
    image += noise;
    image.convertTo(image, CV_8UC3);
    const bool fired = trigger.is_keyframe(make_frame(i, image));
    if (i == 0) {
      EXPECT_TRUE(fired) << "the first frame starts the map";
    } else {
      EXPECT_FALSE(fired) << "frame " << i << ": " << trigger.last_inliers() << " inliers of "
                          << trigger.reference_tracked();
      EXPECT_GT(trigger.last_inliers(), 15) << "frame " << i << ": tracking lost";
    }
  }
}

TEST(OrbSlamTrigger, FiresRepeatedlyOnARealHandHeldVideo) {
  KEYFLEET_REQUIRE_DATA("opencv_samples/video/box.mp4");
  SourceConfig config;
  config.kind = SourceConfig::Kind::kVideoFile;
  config.path = data_path.string();
  config.max_frames = 60;
  config.realtime = false;
  auto source = make_frame_source(config, null_logger());
  std::vector<Frame> frames;
  while (auto frame = source->next()) frames.push_back(*frame);
  ASSERT_EQ(frames.size(), 60u);
  OrbSlamTrigger trigger(default_trigger_params());
  expect_fires_repeatedly(fired_on(trigger, frames), frames.size());
}

// --- GridOrbExtractor --------------------------------------------------------------------------

// Keypoints per image quadrant (0 top-left, 1 top-right, 2 bottom-left, 3 bottom-right).
std::array<int, 4> per_quadrant(const std::vector<cv::KeyPoint>& keypoints, cv::Size size) {
  std::array<int, 4> counts{};
  for (const auto& k : keypoints)
    ++counts[std::size_t((k.pt.y >= size.height / 2.0f ? 2 : 0) + (k.pt.x >= size.width / 2.0f))];
  return counts;
}

void expect_spread_features(const OrbFeatures& features, const GridOrbParams& params, cv::Size size,
                            const std::string& what) {
  const auto& keypoints = features.keypoints;
  EXPECT_GT(keypoints.size(), std::size_t(params.features) / 4) << what;
  EXPECT_LE(keypoints.size(), std::size_t(params.features)) << what;
  EXPECT_EQ(features.descriptors.type(), CV_8U) << what;
  EXPECT_EQ(features.descriptors.cols, 32) << what;
  EXPECT_EQ(std::size_t(features.descriptors.rows), keypoints.size()) << what;
  std::set<int> octaves;
  for (const auto& k : keypoints) {
    EXPECT_TRUE(k.pt.x >= 0 && k.pt.y >= 0 && k.pt.x < size.width && k.pt.y < size.height)
        << what << ": keypoint at " << k.pt;
    octaves.insert(k.octave);
  }
  EXPECT_GT(octaves.size(), 1u) << what << ": features from one pyramid level only";
  const auto quadrants = per_quadrant(keypoints, size);
  for (std::size_t q = 0; q < 4; ++q)
    EXPECT_GE(quadrants[q], int(keypoints.size()) / 10)
        << what << ": quadrant " << q << " holds " << quadrants[q] << " of " << keypoints.size();
}

TEST_F(GeneratedFlight, GridOrbExtractorKeepsTheQuotaSpreadOverAStreetView) {
  GridOrbParams params;
  params.features = 400;
  cv::Mat grey;
  cv::cvtColor((*frames_)[10].image, grey, cv::COLOR_BGR2GRAY);
  expect_spread_features(GridOrbExtractor(params).extract(grey), params, grey.size(),
                         "street view");
}

TEST(GridOrbExtractor, SpreadsFeaturesIntoWeakTextureBesideAStrongPattern) {
  // Strong corners only in the top-left quadrant, faint texture elsewhere.
  cv::Mat grey(480, 640, CV_8U);
  cv::RNG rng(3);
  rng.fill(grey, cv::RNG::UNIFORM, 90, 160);
  cv::GaussianBlur(grey, grey, {0, 0}, 1.2);
  for (int y = 0; y < 240; y += 16)
    for (int x = 0; x < 320; x += 16)
      grey(cv::Rect(x, y, 16, 16)).setTo((x / 16 + y / 16) % 2 ? 255 : 0);
  GridOrbParams params;
  params.features = 1000;
  // Control: OpenCV's plain ORB keeps the strongest corners, nearly all in the checkerboard.
  std::vector<cv::KeyPoint> plain;
  cv::ORB::create(params.features)->detect(grey, plain);
  const auto plain_quadrants = per_quadrant(plain, grey.size());
  ASSERT_LT(plain_quadrants[1] + plain_quadrants[2] + plain_quadrants[3], int(plain.size()) / 20)
      << "the test image no longer concentrates the strong corners in one quadrant";
  expect_spread_features(GridOrbExtractor(params).extract(grey), params, grey.size(),
                         "checkerboard beside faint texture");
}

TEST(GridOrbExtractor, RespectsASmallQuota) {
  GridOrbParams params;
  params.features = 50;
  cv::Mat grey;
  cv::cvtColor(test::make_noise_image(320, 240, 11), grey, cv::COLOR_BGR2GRAY);
  const auto features = GridOrbExtractor(params).extract(grey);
  EXPECT_GT(features.keypoints.size(), 0u);
  EXPECT_LE(features.keypoints.size(), 50u);
  EXPECT_EQ(std::size_t(features.descriptors.rows), features.keypoints.size());
}

// --- ListTrigger -------------------------------------------------------------------------------

std::string write_file(const test::TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.file(name);
  std::ofstream(path) << text;
  return path;
}

TEST(ListTrigger, FiresExactlyOnFramesWithinHalfAPeriodOfAListedTimestamp) {
  test::TempDir dir;
  // At 30 fps frame i is captured at i / 30 s; half a period is 16.7 ms.
  const std::vector<double> listed = {0.0,      // frame 0 exactly
                                      0.51,     // frame 15 (0.5 s) + 10 ms
                                      1.02,     // frame 31 (1.0333 s) - 13 ms
                                      2.3,      // frame 69 (2.3 s)
                                      2.9939};  // frame 90 (3.0 s) - 6 ms
  std::ostringstream text;
  text << "# timestamp tx ty tz qx qy qz qw (ORB-SLAM KeyFrameTrajectory)\n";
  for (double t : listed) text << std::fixed << t << " 0.1 -0.2 1.5 0.0 0.0 0.0 1.0\n";
  ListTrigger trigger(write_file(dir, "KeyFrameTrajectory.txt", text.str()), kFps);
  EXPECT_EQ(trigger.listed(), listed.size());

  std::vector<std::uint64_t> fired;
  for (std::uint64_t i = 0; i < 120; ++i)
    if (trigger.is_keyframe(make_frame(i, cv::Mat()))) fired.push_back(i);
  EXPECT_EQ(fired, (std::vector<std::uint64_t>{0, 15, 31, 69, 90})) << join(fired);

  // Independently: a frame fires exactly when some listed time is within half a period.
  for (std::uint64_t i = 0; i < 120; ++i) {
    bool near = false;
    for (double t : listed) near = near || std::abs(t - double(i) / kFps) < 0.5 / kFps;
    EXPECT_EQ(trigger.is_keyframe(make_frame(i, cv::Mat())), near) << "frame " << i;
  }
}

TEST(ListTrigger, UnsortedListWithBlankLinesStillMatches) {
  test::TempDir dir;
  ListTrigger trigger(write_file(dir, "kf.txt",
                                 "# ORB-SLAM keyframes\n\n2.0 0 0 0 0 0 0 1\n"
                                 "1.0 0 0 0 0 0 0 1\n\n"),
                      kFps);
  EXPECT_EQ(trigger.listed(), 2u);
  EXPECT_TRUE(trigger.is_keyframe(make_frame(30, cv::Mat())));
  EXPECT_TRUE(trigger.is_keyframe(make_frame(60, cv::Mat())));
  EXPECT_FALSE(trigger.is_keyframe(make_frame(45, cv::Mat())));
}

TEST(ListTrigger, MalformedLineIsAStartupErrorNamingFileAndLine) {
  test::TempDir dir;
  const std::string path = write_file(dir, "KeyFrameTrajectory.txt",
                                      "# header\n"
                                      "0.5 0 0 0 0 0 0 1\n"
                                      "one.0 0 0 0 0 0 0 1\n");
  try {
    ListTrigger trigger(path, kFps);
    FAIL() << "expected StartupError";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":3"), std::string::npos) << e.what();
  }
}

TEST(ListTrigger, MissingOrEmptyListIsAStartupErrorNamingTheFile) {
  test::TempDir dir;
  const std::string missing = dir.file("absent.txt");
  try {
    ListTrigger trigger(missing, kFps);
    FAIL() << "expected StartupError";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const std::string empty = write_file(dir, "empty.txt", "# nothing\n");
  EXPECT_THROW(ListTrigger(empty, kFps), StartupError);
}

// --- StrideTrigger -----------------------------------------------------------------------------

TEST(StrideTrigger, FiresEveryStrideFrames) {
  StrideTrigger trigger(15);
  std::vector<std::uint64_t> fired;
  for (std::uint64_t i = 0; i < 50; ++i)
    if (trigger.is_keyframe(make_frame(i, cv::Mat()))) fired.push_back(i);
  EXPECT_EQ(fired, (std::vector<std::uint64_t>{0, 15, 30, 45}));
}

}  // namespace
}  // namespace keyfleet::agent
