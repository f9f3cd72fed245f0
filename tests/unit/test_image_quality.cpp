// Per-frame image quality: blur energy and brightness react to blur and bad exposure, and the
// Kumar sharpness falls with motion blur on real photos and on generated frames with known blur.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/image_quality.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/eval/image_quality_reference.hpp"
#include "keyfleet/scenario/camera_effects.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "test_support.hpp"

namespace keyfleet::agent {
namespace {

namespace fs = std::filesystem;

constexpr char kSharpPhotos[] = "icdar2015/train_sharp/images";

// The sorted *.jpg files of a folder.
std::vector<fs::path> jpg_files(const fs::path& folder) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.is_regular_file() && entry.path().extension() == ".jpg")
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

cv::Mat grey_of(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

// Grey, downscaled to `width` as the selector measures sharpness (never upscaled).
cv::Mat grey_at_width(const cv::Mat& bgr, int width) {
  cv::Mat grey = grey_of(bgr);
  const double f = double(width) / grey.cols;
  if (f < 1) cv::resize(grey, grey, {}, f, f, cv::INTER_AREA);
  return grey;
}

cv::Mat motion_blurred(const cv::Mat& image, double length_px, double angle_deg) {
  cv::Mat out;
  cv::filter2D(image, out, -1, scenario::motion_blur_kernel(length_px, angle_deg), {-1, -1}, 0,
               cv::BORDER_REPLICATE);
  return out;
}

cv::Mat gaussian_blurred(const cv::Mat& image, double sigma) {
  cv::Mat out;
  cv::GaussianBlur(image, out, {0, 0}, sigma);
  return out;
}

cv::Mat with_gain(const cv::Mat& bgr, double gain) {
  cv::Mat out;
  bgr.convertTo(out, -1, gain);  // saturates at 255
  return out;
}

double mean_lightness(const cv::Mat& bgr) {  // CIELAB L in [0, 100]
  cv::Mat lab;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);
  return cv::mean(lab)[0] * 100.0 / 255.0;
}

// A mid-grey street-like scene: a soft gradient, blocks and dark words (sharp edges).
cv::Mat make_scene(int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(std::uint8_t(90 + 60 * x / width), std::uint8_t(110 + 40 * y / height),
                    std::uint8_t(120 + 30 * (x + y) / (width + height)));
  cv::rectangle(image, cv::Rect(width / 10, height / 6, width / 3, height / 4),
                cv::Scalar(200, 210, 220), cv::FILLED);
  cv::rectangle(image, cv::Rect(width / 2, height / 2, width / 3, height / 3),
                cv::Scalar(40, 60, 50), cv::FILLED);
  cv::putText(image, "BAKERY", {width / 10 + 4, height / 6 + height / 6}, cv::FONT_HERSHEY_SIMPLEX,
              width / 400.0, cv::Scalar(20, 20, 20), 2, cv::LINE_AA);
  cv::putText(image, "OPEN 24H", {width / 8, 7 * height / 8}, cv::FONT_HERSHEY_DUPLEX,
              width / 500.0, cv::Scalar(240, 240, 240), 2, cv::LINE_AA);
  return image;
}

std::string join(const std::vector<double>& values) {
  std::ostringstream out;
  for (std::size_t i = 0; i < values.size(); ++i) out << (i ? ", " : "") << values[i];
  return out.str();
}

namespace reference = keyfleet::eval::reference;

// The agent's parameters (QualityConfig) and the defaults of SharpnessParams.
std::vector<SharpnessParams> sharpness_params() {
  const QualityConfig quality;
  return {SharpnessParams{}, SharpnessParams{quality.edge_contrast, quality.sharp_ratio},
          SharpnessParams{50, 1.7}, SharpnessParams{0, 0}, SharpnessParams{100.5, 0.3}};
}

void expect_same_as_reference(const cv::Mat& grey, const std::string& what) {
  SharpnessScratch scratch;  // reused across parameters and calls, as the selector does
  for (const auto& params : sharpness_params()) {
    const double expected = reference::kumar_sharpness(grey, params);
    EXPECT_EQ(kumar_sharpness(grey, params, scratch), expected)
        << what << " (" << grey.cols << "x" << grey.rows << ", edge contrast "
        << params.edge_contrast << ", ratio " << params.sharp_ratio << ")";
    EXPECT_EQ(kumar_sharpness(grey, params), expected) << what << " (fresh scratch)";
  }
  EXPECT_NEAR(energy_of_laplacian(grey), reference::energy_of_laplacian(grey),
              1e-5 * reference::energy_of_laplacian(grey) + 1e-3)
      << what;
}

// Largest difference between two 8-bit images of the same size, and the fraction that differ.
std::pair<int, double> difference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  double largest = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &largest);
  return {int(largest),
          double(cv::countNonZero(diff.reshape(1))) / double(diff.total() * diff.channels())};
}

constexpr double kBlurLengths[] = {0, 2, 4, 8, 16};

// Kumar sharpness of `grey` blurred by each of kBlurLengths along `angle_deg`.
std::vector<double> sharpness_by_blur(const cv::Mat& grey, double angle_deg) {
  std::vector<double> scores;
  for (double length : kBlurLengths)
    scores.push_back(kumar_sharpness(motion_blurred(grey, length, angle_deg)));
  return scores;
}

void expect_strictly_falling(const std::vector<double>& scores, const std::string& what) {
  for (std::size_t i = 1; i < scores.size(); ++i)
    EXPECT_LT(scores[i], scores[i - 1])
        << what << ": blur " << kBlurLengths[i] << " px vs " << kBlurLengths[i - 1]
        << " px; scores for 0,2,4,8,16 px: " << join(scores);
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

// --- energy of Laplacian and brightness -------------------------------------------------------

void expect_blur_lowers_energy(const cv::Mat& bgr, const std::string& what) {
  const cv::Mat grey = grey_of(bgr);
  const double sharp = energy_of_laplacian(grey);
  EXPECT_GT(sharp, 0.0) << what;
  EXPECT_LT(energy_of_laplacian(gaussian_blurred(grey, 1.5)), sharp) << what << ": Gaussian";
  EXPECT_LT(energy_of_laplacian(motion_blurred(grey, 9, 20)), sharp) << what << ": motion";
  EXPECT_LT(energy_of_laplacian(gaussian_blurred(grey, 4.0)),
            energy_of_laplacian(gaussian_blurred(grey, 1.5)))
      << what << ": more blur, less energy";
}

void expect_bad_exposure_lowers_brightness(const cv::Mat& bgr, const std::string& what) {
  const double original = brightness_score(bgr);
  EXPECT_GT(original, 0.0) << what;
  EXPECT_LT(brightness_score(with_gain(bgr, 2.5)), original) << what << ": over-exposed x2.5";
  EXPECT_LT(brightness_score(with_gain(bgr, 0.3)), original) << what << ": under-exposed x0.3";
}

TEST(EnergyOfLaplacian, BlurredCopyOfASyntheticSceneScoresLower) {
  expect_blur_lowers_energy(make_scene(320, 240), "synthetic scene");
}

TEST(EnergyOfLaplacian, FlatImageHasNoEnergy) {
  // Zero up to the float rounding of the kernel's (1/6) weights.
  EXPECT_LT(energy_of_laplacian(cv::Mat(48, 64, CV_8U, cv::Scalar(77))), 1e-3);
}

TEST(EnergyOfLaplacian, BlurredCopiesOfRealPhotosScoreLower) {
  KEYFLEET_REQUIRE_DATA(kSharpPhotos);
  const auto files = jpg_files(data_path);
  ASSERT_GE(files.size(), 3u) << data_path;
  for (const auto& file : files) {
    const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << file;
    expect_blur_lowers_energy(bgr, file.filename().string());
    // And at the selector's 112 x 112 measuring size.
    cv::Mat small;
    cv::resize(bgr, small, {112, 112}, 0, 0, cv::INTER_AREA);
    expect_blur_lowers_energy(small, file.filename().string() + " at 112x112");
  }
}

TEST(BrightnessScore, OverAndUnderExposedSyntheticSceneScoresLower) {
  const cv::Mat scene = make_scene(320, 240);
  ASSERT_NEAR(mean_lightness(scene), 50, 15) << "the scene must start well exposed";
  expect_bad_exposure_lowers_brightness(scene, "synthetic scene");
  expect_bad_exposure_lowers_brightness(test::make_smooth_image(160, 120), "smooth image");
}

TEST(BrightnessScore, FlatMidGreyScoresHigherThanBlackOrWhite) {
  const cv::Mat grey(32, 32, CV_8UC3, cv::Scalar::all(119));  // L close to 50
  EXPECT_GT(brightness_score(grey), brightness_score(cv::Mat(32, 32, CV_8UC3, cv::Scalar::all(0))));
  EXPECT_GT(brightness_score(grey),
            brightness_score(cv::Mat(32, 32, CV_8UC3, cv::Scalar::all(255))));
}

TEST(BrightnessScore, OverAndUnderExposedRealPhotosScoreLower) {
  KEYFLEET_REQUIRE_DATA(kSharpPhotos);
  int tested = 0;
  for (const auto& file : jpg_files(data_path)) {
    const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << file;
    // Brightening a photo that is already dark brings it toward mid-grey, which is right to
    // score higher: only photos that start reasonably exposed can be over-exposed.
    const double lightness = mean_lightness(bgr);
    if (lightness < 30 || lightness > 70) continue;
    ++tested;
    expect_bad_exposure_lowers_brightness(bgr, file.filename().string());
    cv::Mat small;
    cv::resize(bgr, small, {112, 112}, 0, 0, cv::INTER_AREA);
    expect_bad_exposure_lowers_brightness(small, file.filename().string() + " at 112x112");
  }
  EXPECT_GE(tested, 3) << "too few well-exposed photos in " << data_path;
}

// --- Kumar sharpness ---------------------------------------------------------------------------

TEST(KumarSharpness, LiesInTheUnitIntervalAndIsZeroWithoutEdges) {
  EXPECT_EQ(kumar_sharpness(cv::Mat(60, 80, CV_8U, cv::Scalar(128))), 0.0);
  const double s = kumar_sharpness(grey_of(make_scene(320, 240)));
  EXPECT_GT(s, 0.0);
  EXPECT_LE(s, 1.0);
}

TEST(KumarSharpness, FallsMonotonicallyWithMotionBlurOnASyntheticScene) {
  const cv::Mat grey = grey_of(make_scene(320, 240));
  expect_strictly_falling(sharpness_by_blur(grey, 0), "synthetic scene, 0 deg");
  expect_strictly_falling(sharpness_by_blur(grey, 30), "synthetic scene, 30 deg");
}

TEST(KumarSharpness, FallsMonotonicallyWithMotionBlurOnRealPhotos) {
  KEYFLEET_REQUIRE_DATA(kSharpPhotos);
  const auto files = jpg_files(data_path);
  ASSERT_GE(files.size(), 3u) << data_path;
  for (const auto& file : files) {
    const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << file;
    const cv::Mat grey = grey_at_width(bgr, 320);
    for (double angle : {0.0, 30.0, 90.0})
      expect_strictly_falling(
          sharpness_by_blur(grey, angle),
          file.filename().string() + " at 320 px, " + std::to_string(int(angle)) + " deg");
  }
}

// Ma and Zhao's sharpness gate (QualityConfig::sharpness_gate, measured at sharpness_width) must
// let sharp photos through and stop clearly motion-blurred ones.
TEST(KumarSharpness, DefaultGateSeparatesSharpPhotosFromEightPixelMotionBlur) {
  KEYFLEET_REQUIRE_DATA(kSharpPhotos);
  const QualityConfig quality;
  const auto files = jpg_files(data_path);
  ASSERT_GE(files.size(), 3u) << data_path;
  for (const auto& file : files) {
    const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << file;
    const cv::Mat grey = grey_at_width(bgr, quality.sharpness_width);
    const double sharp = kumar_sharpness(grey);
    EXPECT_GT(sharp, quality.sharpness_gate) << file.filename() << " (sharp)";
    for (double length : {8.0, 16.0}) {
      const double blurred = kumar_sharpness(motion_blurred(grey, length, 30));
      EXPECT_LT(blurred, quality.sharpness_gate)
          << file.filename() << " blurred " << length << " px at " << quality.sharpness_width
          << " px width scores " << blurred << " (sharp: " << sharp << ")";
    }
  }
}

// The fused implementation counts exactly what the float formulation counts (median,
// differences with replicated border, 3x3 sums with reflected border, both thresholds),
// for several parameters, on sharp and blurred photos and on images a few pixels wide.
TEST(KumarSharpness, EqualsTheOpenCvFormulationOnRealPhotos) {
  KEYFLEET_REQUIRE_DATA(kSharpPhotos);
  for (const auto& file : jpg_files(data_path)) {
    const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << file;
    const cv::Mat grey = grey_at_width(bgr, 320);
    expect_same_as_reference(grey, file.filename().string());
    expect_same_as_reference(motion_blurred(grey, 8, 30), file.filename().string() + " 8 px");
    expect_same_as_reference(grey_at_width(bgr, 97), file.filename().string() + " at 97 px");
  }
}

TEST(KumarSharpness, EqualsTheOpenCvFormulationOnSmallAndSyntheticImages) {
  expect_same_as_reference(grey_of(make_scene(320, 240)), "synthetic scene");
  expect_same_as_reference(grey_of(make_scene(173, 61)), "synthetic scene, odd size");
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(2, 2), cv::Size(3, 3), cv::Size(1, 9),
                              cv::Size(9, 1), cv::Size(5, 7), cv::Size(17, 4), cv::Size(64, 48)}) {
    cv::Mat noise(size, CV_8UC1);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
    expect_same_as_reference(noise, "noise");
    expect_same_as_reference(cv::Mat(size, CV_8UC1, cv::Scalar(90)), "flat");
  }
}

TEST(BrightnessScore, EqualsTheOpenCvFormulation) {
  for (const cv::Mat& bgr :
       {make_scene(320, 240), make_scene(112, 112), test::make_smooth_image(160, 120),
        cv::Mat(32, 32, CV_8UC3, cv::Scalar::all(255))}) {
    const double expected = reference::brightness_score(bgr);
    EXPECT_NEAR(brightness_score(bgr), expected, 1e-9 * expected);
  }
}

// Every 8-bit colour: lab_lightness gives cv::cvtColor's L to the level (a table built
// differently, a weight rounded the other way or another OpenCV's arithmetic fails here).
TEST(BrightnessScore, LightnessIsOpenCvsOnEveryColour) {
  cv::Mat all(4096, 4096, CV_8UC3);
  for (int i = 0; i < 4096 * 4096; ++i) {
    std::uint8_t* p = all.data + 3 * std::size_t(i);
    p[0] = std::uint8_t(i), p[1] = std::uint8_t(i >> 8), p[2] = std::uint8_t(i >> 16);
  }
  cv::Mat lab;
  cv::cvtColor(all, lab, cv::COLOR_BGR2Lab);
  int differ = 0;
  for (int i = 0; i < 4096 * 4096; ++i) {
    const std::uint8_t* p = all.data + 3 * std::size_t(i);
    if (lab_lightness(p[0], p[1], p[2]) != lab.data[3 * std::size_t(i)] && ++differ <= 3)
      ADD_FAILURE() << "BGR " << int(p[0]) << " " << int(p[1]) << " " << int(p[2]) << ": "
                    << int(lab_lightness(p[0], p[1], p[2])) << " against OpenCV's "
                    << int(lab.data[3 * std::size_t(i)]);
  }
  EXPECT_EQ(differ, 0);
  // A BGRA image scores the same as its BGR (the fourth channel ignored).
  const cv::Mat bgr = make_scene(64, 48);
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  EXPECT_EQ(brightness_score(bgra), brightness_score(bgr));
}

// The area resize the selector uses agrees with OpenCV's INTER_AREA to within one grey level
// (a float sum rounded differently), on 3- and 1-channel images, integer and other factors.
TEST(AreaResizer, AgreesWithOpenCvInterArea) {
  const cv::Mat scene = make_scene(640, 480);
  AreaResizer resizer;  // reused: tables rebuilt when the sizes change
  for (const auto& [from, to] :
       std::vector<std::pair<cv::Size, cv::Size>>{{{640, 480}, {320, 240}},
                                                  {{320, 240}, {112, 112}},
                                                  {{640, 480}, {112, 112}},
                                                  {{333, 250}, {112, 112}},
                                                  {{320, 240}, {112, 112}},
                                                  {{97, 61}, {40, 13}},
                                                  {{112, 112}, {112, 112}}}) {
    cv::Mat bgr, grey, ours, theirs;
    cv::resize(scene, bgr, from, 0, 0, cv::INTER_LINEAR);
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    for (const cv::Mat& image : {bgr, grey}) {
      resizer.resize(image, ours, to);
      cv::resize(image, theirs, to, 0, 0, cv::INTER_AREA);
      ASSERT_EQ(ours.size(), to);
      ASSERT_EQ(ours.type(), image.type());
      const auto [largest, fraction] = difference(ours, theirs);
      EXPECT_LE(largest, 1) << from << " -> " << to << ", " << image.channels() << " channels";
      EXPECT_LT(fraction, 0.01) << from << " -> " << to << ", " << image.channels() << " channels";
    }
  }
}

// Against the definition: each output pixel is the mean of the source area it covers
// (overlaps computed in double here), rounded to the nearest level.
TEST(AreaResizer, RoundsTheExactAreaMean) {
  const cv::Mat scene = make_scene(320, 240);
  AreaResizer resizer;
  for (const auto& [from, to] : std::vector<std::pair<cv::Size, cv::Size>>{
           {{320, 240}, {112, 112}}, {{97, 61}, {40, 13}}, {{50, 50}, {49, 3}}}) {
    cv::Mat bgr, ours;
    cv::resize(scene, bgr, from, 0, 0, cv::INTER_LINEAR);
    resizer.resize(bgr, ours, to);
    const double sx = double(from.width) / to.width, sy = double(from.height) / to.height;
    auto overlap = [](double lo, double hi, int j) {
      return std::max(0.0, std::min(hi, j + 1.0) - std::max(lo, double(j)));
    };
    double worst = 0;
    for (int y = 0; y < to.height; ++y)
      for (int x = 0; x < to.width; ++x)
        for (int c = 0; c < 3; ++c) {
          double mean = 0;
          for (int j = int(y * sy); j < std::min(from.height, int(std::ceil((y + 1) * sy))); ++j)
            for (int i = int(x * sx); i < std::min(from.width, int(std::ceil((x + 1) * sx))); ++i)
              mean += overlap(y * sy, (y + 1) * sy, j) * overlap(x * sx, (x + 1) * sx, i) *
                      bgr.at<cv::Vec3b>(j, i)[c];
          mean /= sx * sy;
          worst = std::max(worst, std::abs(ours.at<cv::Vec3b>(y, x)[c] - mean));
        }
    EXPECT_LE(worst, 0.5 + 1e-9) << from << " -> " << to;
  }
}

// What the selector measures on a 640x480 frame: the grey copy at 320 px is exactly the one
// OpenCV's resize and conversion give; 112 x 112 within one grey level.
TEST(QualityImages, MatchTheOpenCvPipelineOnACameraFrame) {
  const cv::Mat frame = make_scene(640, 480);
  const QualityConfig quality;
  QualityImages images;
  for (int round = 0; round < 2; ++round) {  // the second time on reused buffers
    images.prepare(frame, quality.size, quality.sharpness_width);
    cv::Mat work, work_grey, small, grey;
    cv::resize(frame, work, {}, 0.5, 0.5, cv::INTER_AREA);
    cv::cvtColor(work, work_grey, cv::COLOR_BGR2GRAY);
    cv::resize(work, small, {quality.size, quality.size}, 0, 0, cv::INTER_AREA);
    cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(difference(images.work_grey, work_grey).first, 0);
    EXPECT_LE(difference(images.small, small).first, 1);
    EXPECT_LE(difference(images.grey, grey).first, 1);
  }
  // A frame no wider than the sharpness width is measured as it is.
  const cv::Mat narrow = make_scene(320, 240);
  images.prepare(narrow, quality.size, quality.sharpness_width);
  EXPECT_EQ(images.work.data, narrow.data);
  EXPECT_EQ(difference(images.work_grey, grey_of(narrow)).first, 0);
}

// One drone of a small generated street: frames with ground-truth motion blur.
class ScenarioSharpness : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    ScenarioConfig config;
    config.seed = 3;
    config.frames_per_drone = 120;
    config.width = 320;
    config.height = 240;
    config.street.length_m = 60;
    config.drones.count = 1;
    config.drones.shake_burst_rate_hz = 0.5;  // bursts within 4 s of flight
    config.camera.exposure_event_rate_hz = 0.5;
    scenario::generate_scenario(config, dir_->file("street"), null_logger());
    const auto s = scenario::read_scenario(dir_->file("street"));
    drone_dir_ = new fs::path(dir_->path() / "street" / s.drones.at(0).folder);
    truth_ =
        new std::vector<scenario::FrameTruth>(scenario::read_frame_truth(drone_dir_->string()));
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete drone_dir_;
    delete dir_;
  }
  static cv::Mat image(const scenario::FrameTruth& frame) {
    return cv::imread((*drone_dir_ / frame.image).string(), cv::IMREAD_COLOR);
  }
  static test::TempDir* dir_;
  static fs::path* drone_dir_;
  static std::vector<scenario::FrameTruth>* truth_;
};
test::TempDir* ScenarioSharpness::dir_ = nullptr;
fs::path* ScenarioSharpness::drone_dir_ = nullptr;
std::vector<scenario::FrameTruth>* ScenarioSharpness::truth_ = nullptr;

TEST_F(ScenarioSharpness, FallsMonotonicallyWithMotionBlurOnGeneratedFrames) {
  int tested = 0;
  for (const auto& frame : *truth_) {
    if (frame.motion_blur_px >= 1 || frame.index % 20 != 0) continue;
    const cv::Mat grey = grey_at_width(image(frame), 320);
    ASSERT_FALSE(grey.empty());
    expect_strictly_falling(sharpness_by_blur(grey, 0),
                            "generated frame " + std::to_string(frame.index));
    ++tested;
  }
  EXPECT_GE(tested, 3);
}

TEST_F(ScenarioSharpness, FramesWithStrongTruthBlurHaveALowerMedianSharpness) {
  std::vector<double> sharp, blurred;
  for (const auto& frame : *truth_) {
    const double s = kumar_sharpness(grey_at_width(image(frame), 320));
    if (frame.motion_blur_px < 1) sharp.push_back(s);
    if (frame.motion_blur_px > 8) blurred.push_back(s);
  }
  ASSERT_GE(sharp.size(), 10u) << "too few frames with less than 1 px of blur";
  ASSERT_GE(blurred.size(), 3u) << "no shake burst blurred frames by more than 8 px";
  EXPECT_LT(median(blurred), median(sharp))
      << "blurred: " << join(blurred) << "; sharp median " << median(sharp);
}

}  // namespace
}  // namespace keyfleet::agent
