// The scenario generator: ground truth consistent with the pixels, deterministic, blur
// ground truth that matches the images, a reader that round-trips, clear config errors.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <set>

#include "keyfleet/agent/frame_source.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/fnv1a.hpp"
#include "keyfleet/scenario/camera_effects.hpp"
#include "keyfleet/scenario/flight.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "test_support.hpp"

namespace keyfleet::scenario {
namespace {

namespace fs = std::filesystem;

ScenarioConfig small_config(std::uint64_t seed = 3) {
  ScenarioConfig c;
  c.seed = seed;
  c.frames_per_drone = 90;
  c.width = 320;
  c.height = 240;
  c.street.length_m = 60;
  c.drones.count = 3;
  c.drones.speed_mps = 2.0;
  c.drones.shake_burst_rate_hz = 0.5;  // bursts within 3 s of flight
  c.camera.exposure_event_rate_hz = 0.5;
  return c;
}

double laplacian_energy(const cv::Mat& bgr) {
  cv::Mat grey, lap;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::Laplacian(grey, lap, CV_64F);
  return cv::mean(lap.mul(lap))[0];
}

std::map<std::string, std::uint64_t> file_hashes(const fs::path& root) {
  std::map<std::string, std::uint64_t> hashes;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
    hashes[fs::relative(entry.path(), root).string()] = fnv1a64(bytes);
  }
  return hashes;
}

class GeneratedScenario : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    summary_ = new GenerationSummary(
        generate_scenario(small_config(), (dir_->path() / "a").string(), null_logger()));
  }
  static void TearDownTestSuite() {
    delete summary_;
    delete dir_;
  }
  static fs::path root() { return dir_->path() / "a"; }
  static test::TempDir* dir_;
  static GenerationSummary* summary_;
};
test::TempDir* GeneratedScenario::dir_ = nullptr;
GenerationSummary* GeneratedScenario::summary_ = nullptr;

TEST_F(GeneratedScenario, WritesEveryDroneFrameAndTruthLine) {
  const Scenario s = read_scenario(root().string());
  ASSERT_EQ(s.drones.size(), 3u);
  EXPECT_EQ(s.drones[0].day, 0);
  EXPECT_EQ(s.drones[1].day, 1);
  EXPECT_EQ(s.drones[2].day, 0);
  EXPECT_FALSE(s.signs.empty());
  for (const auto& drone : s.drones) {
    const auto truth = read_frame_truth((root() / drone.folder).string());
    ASSERT_EQ(truth.size(), 90u);
    const cv::Mat first = cv::imread((root() / drone.folder / truth[0].image).string());
    EXPECT_EQ(first.size(), cv::Size(320, 240));
    EXPECT_EQ(truth[30].timestamp_ns, 1'000'000'000);
    EXPECT_TRUE(fs::exists(root() / drone.folder / "poses_tum.txt"));
  }
  EXPECT_EQ(summary_->frames, 270u);
  EXPECT_GT(summary_->bytes_on_disk, 0u);
}

TEST_F(GeneratedScenario, FullyVisibleWordsLieInsideTheFrameAndOthersAreMarked) {
  const Scenario s = read_scenario(root().string());
  std::map<WordVisibility, int> counts;
  for (const auto& drone : s.drones)
    for (const auto& frame : read_frame_truth((root() / drone.folder).string()))
      for (const auto& word : frame.words) {
        ++counts[word.visibility];
        bool inside = true;
        for (const auto& p : word.quad)
          inside = inside && p.x >= -0.5 && p.y >= -0.5 && p.x <= 320.5 && p.y <= 240.5;
        if (word.visibility == WordVisibility::kFull) {
          EXPECT_TRUE(inside) << word.text << " frame " << frame.index;
          EXPECT_GT(word.visible_fraction, 0.85);
        }
        if (word.visibility == WordVisibility::kCut) {
          EXPECT_FALSE(inside) << word.text;
        }
        EXPECT_GE(word.box_x0, 0);
        EXPECT_LE(word.box_x1, 320);
        EXPECT_EQ(word.text, s.signs.at(std::size_t(word.sign_id)).text);
      }
  EXPECT_GT(counts[WordVisibility::kFull], 20);
  EXPECT_GT(counts[WordVisibility::kCut], 0);
}

TEST_F(GeneratedScenario, TheSameSignSeenByTwoDronesMapsToTheSamePlace) {
  const Scenario s = read_scenario(root().string());
  std::map<int, std::set<std::string>> seen_by;
  for (const auto& drone : s.drones)
    for (const auto& frame : read_frame_truth((root() / drone.folder).string()))
      for (const auto& word : frame.words) {
        const SignTruth& sign = s.signs.at(std::size_t(word.sign_id));
        EXPECT_EQ(word.place_id, sign.place_id);
        const double x = (sign.word_corners[0].x + sign.word_corners[1].x) / 2;
        EXPECT_EQ(sign.place_id, int(std::floor(x / s.place_length_m)));
        if (word.visibility == WordVisibility::kFull) seen_by[word.sign_id].insert(drone.robot_id);
        // The quad is the sign's world corners projected with the frame's true pose.
        const Pose& p = frame.camera_to_world;
        const Eigen::Quaterniond q(p.qw, p.qx, p.qy, p.qz);
        const Eigen::Matrix3d r_cw = q.toRotationMatrix().transpose();
        for (std::size_t i = 0; i < 4; ++i) {
          const auto& w = sign.word_corners[i];
          const Eigen::Vector3d c =
              r_cw * (Eigen::Vector3d(w.x, w.y, w.z) - Eigen::Vector3d(p.tx, p.ty, p.tz));
          const double u = drone.camera.fx * c.x() / c.z() + drone.camera.cx;
          const double v = drone.camera.fy * c.y() / c.z() + drone.camera.cy;
          EXPECT_NEAR(u, word.quad[i].x, 0.01);
          EXPECT_NEAR(v, word.quad[i].y, 0.01);
        }
      }
  const auto shared = std::count_if(seen_by.begin(), seen_by.end(),
                                    [](const auto& entry) { return entry.second.size() >= 2; });
  EXPECT_GT(shared, 0) << "no sign was seen by two drones";
}

TEST_F(GeneratedScenario, MoreMotionBlurMeansLessLaplacianEnergy) {
  // Across frames, blur length and sharpness must be clearly anti-correlated (Spearman).
  const Scenario s = read_scenario(root().string());
  std::vector<double> blur, energy;
  for (const auto& drone : s.drones)
    for (const auto& frame : read_frame_truth((root() / drone.folder).string())) {
      blur.push_back(frame.motion_blur_px);
      energy.push_back(
          laplacian_energy(cv::imread((root() / drone.folder / frame.image).string())));
    }
  auto ranks = [](const std::vector<double>& v) {
    std::vector<std::size_t> order(v.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return v[a] < v[b]; });
    std::vector<double> r(v.size());
    for (std::size_t i = 0; i < order.size(); ++i) r[order[i]] = double(i);
    return r;
  };
  const auto rb = ranks(blur), re = ranks(energy);
  const double n = double(rb.size());
  double d2 = 0;
  for (std::size_t i = 0; i < rb.size(); ++i) d2 += (rb[i] - re[i]) * (rb[i] - re[i]);
  const double spearman = 1 - 6 * d2 / (n * (n * n - 1));
  EXPECT_LT(spearman, -0.3) << "blur ground truth does not match the images";
  EXPECT_GT(*std::max_element(blur.begin(), blur.end()), 4.0) << "no shake burst blurred a frame";
}

TEST(CameraEffectsBlur, EnergyFallsMonotonicallyWithBlurLength) {
  const cv::Mat scene = test::make_noise_image(320, 240, 5);
  cv::Mat radiance;
  scene.convertTo(radiance, CV_32FC3);
  CameraEffectsConfig config;
  config.noise_sigma = 0, config.shot_noise = 0, config.vignetting = 0;
  double previous = 1e300;
  for (double length : {0.0, 2.0, 4.0, 8.0, 16.0}) {
    CameraEffects effects(config, scene.size(), 30, 1);
    AppliedEffects applied;
    const double e = laplacian_energy(effects.apply(radiance, length, 30, applied));
    EXPECT_LT(e, previous) << "blur " << length;
    previous = e;
  }
}

TEST(ScenarioDeterminism, SameSeedSameBytesOtherSeedOtherBytes) {
  test::TempDir dir;
  ScenarioConfig c = small_config(11);
  c.frames_per_drone = 20;
  c.drones.count = 2;
  generate_scenario(c, (dir.path() / "a").string(), null_logger(), 2);
  generate_scenario(c, (dir.path() / "b").string(), null_logger(), 1);
  c.seed = 12;
  generate_scenario(c, (dir.path() / "c").string(), null_logger());
  const auto a = file_hashes(dir.path() / "a"), b = file_hashes(dir.path() / "b"),
             other = file_hashes(dir.path() / "c");
  EXPECT_EQ(a, b) << "threads must not change the bytes";
  EXPECT_NE(a.at("drone_0/frames/000000.jpg"), other.at("drone_0/frames/000000.jpg"));
}

TEST(ScenarioGenerate, RefusesToOverwriteAScenario) {
  test::TempDir dir;
  ScenarioConfig c = small_config();
  c.frames_per_drone = 2;
  c.drones.count = 1;
  generate_scenario(c, dir.path().string(), null_logger());
  EXPECT_THROW(generate_scenario(c, dir.path().string(), null_logger()), StartupError);
}

TEST(ScenarioReader, TruthLineRoundTrips) {
  FrameTruth f;
  f.index = 7;
  f.timestamp_ns = 233333333;
  f.image = "frames/000007.jpg";
  f.camera_to_world = Pose{1, 2, 3, 0, 0, 0.6, 0.8};
  f.motion_blur_px = 3.5;
  f.exposure_event = "over";
  f.place_id = 4;
  WordInView w;
  w.sign_id = 2, w.text = "HOTEL", w.visibility = WordVisibility::kOccluded;
  w.quad[2] = {10.5, 20.25};
  f.words.push_back(w);
  test::TempDir dir;
  std::ofstream(dir.path() / "truth.jsonl") << frame_truth_line(f) << "\n";
  const auto back = read_frame_truth(dir.path().string());
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].index, 7u);
  EXPECT_EQ(back[0].camera_to_world.qz, 0.6);
  EXPECT_EQ(back[0].exposure_event, "over");
  ASSERT_EQ(back[0].words.size(), 1u);
  EXPECT_EQ(back[0].words[0].visibility, WordVisibility::kOccluded);
  EXPECT_EQ(back[0].words[0].quad[2].y, 20.25);
}

TEST(ScenarioReader, MalformedTruthNamesFileAndLine) {
  test::TempDir dir;
  std::ofstream(dir.path() / "truth.jsonl") << "{\"index\": 0}\n";
  try {
    read_frame_truth(dir.path().string());
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("truth.jsonl:1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_scenario(dir.path().string()), std::runtime_error);
}

// Integer fields take JSON integers that fit: a float where an integer belongs (8.3e19 as a
// timestamp once made the reader cast out of range, undefined behaviour that fuzz_scenario_truth
// found), one too large, or a string is a clear error naming the file and line.
TEST(ScenarioReader, IntegerFieldsRefuseFloatsAndOutOfRangeValues) {
  FrameTruth f;
  f.image = "frames/000000.jpg";
  const nlohmann::json good = nlohmann::json::parse(frame_truth_line(f));
  const std::vector<std::pair<std::string, nlohmann::json>> bad = {
      {"timestamp_ns", 8.28571e19},
      {"timestamp_ns", 1.5},
      {"index", -1},
      {"place", 4294967296LL},
      {"place", "3"},
      {"timestamp_ns", nlohmann::json::parse("18446744073709551615")}};
  for (const auto& [key, value] : bad) {
    nlohmann::json line = good;
    line[key] = value;
    test::TempDir dir;
    std::ofstream(dir.path() / "truth.jsonl") << good.dump() << "\n" << line.dump() << "\n";
    try {
      read_frame_truth(dir.path().string());
      ADD_FAILURE() << key << " = " << value.dump() << " was accepted";
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("truth.jsonl:2"), std::string::npos) << message;
      EXPECT_NE(message.find("integer"), std::string::npos) << message;
    }
  }
  nlohmann::json largest = good;
  largest["timestamp_ns"] = std::numeric_limits<std::int64_t>::max();
  test::TempDir dir;
  std::ofstream(dir.path() / "truth.jsonl") << largest.dump() << "\n";
  EXPECT_EQ(read_frame_truth(dir.path().string()).at(0).timestamp_ns,
            std::numeric_limits<std::int64_t>::max());
}

// A scenario file's robot ids and folders become paths: one that climbs out of the run or
// scenario folder ("../../x") is refused with the file named.
TEST_F(GeneratedScenario, RobotIdsAndFoldersThatLeaveTheirFolderAreRefused) {
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"robot_id", "../../x"}, {"folder", "../outside"}}) {
    nlohmann::json doc = nlohmann::json::parse(std::ifstream(root() / "scenario.json"));
    doc["drones"][0][key] = value;
    test::TempDir dir;
    std::ofstream(dir.path() / "scenario.json") << doc.dump();
    try {
      read_scenario(dir.path().string());
      ADD_FAILURE() << key << " '" << value << "' was accepted";
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("scenario.json"), std::string::npos) << message;
      EXPECT_NE(message.find(value), std::string::npos) << message;
    }
  }
}

TEST(ScenarioConfigErrors, UnknownKeyNegativeSpeedMissingTextureFolder) {
  auto error_of = [](const std::string& text) {
    try {
      parse_scenario_config(text, "scenario.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of("drones:\n  speeed_mps: 2\n").find("drones.speeed_mps: unknown key"),
            std::string::npos);
  EXPECT_NE(error_of("drones:\n  speed_mps: -2\n").find("drones.speed_mps: must be between"),
            std::string::npos);
  EXPECT_NE(error_of("textures:\n  photo_folders: [/nonexistent/photos]\n")
                .find("textures.photo_folders: '/nonexistent/photos' is not a folder"),
            std::string::npos);
  EXPECT_NE(error_of("frames_per_drone: 100000\n").find("would leave the street"),
            std::string::npos);
}

TEST(ScenarioSource, ReplaysADroneWithItsPosesAndRejectsAnUnknownDrone) {
  test::TempDir dir;
  ScenarioConfig c = small_config();
  c.frames_per_drone = 5;
  c.drones.count = 2;
  generate_scenario(c, dir.path().string(), null_logger());
  SourceConfig source;
  source.kind = SourceConfig::Kind::kScenario;
  source.path = dir.path().string();
  source.drone = "drone_1";
  auto frames = agent::make_frame_source(source, null_logger());
  int n = 0;
  while (auto frame = frames->next()) {
    EXPECT_TRUE(frame->pose.has_value());
    EXPECT_EQ(frame->image.cols, 320);
    ++n;
  }
  EXPECT_EQ(n, 5);
  source.drone = "drone_9";
  EXPECT_THROW(agent::make_frame_source(source, null_logger()), StartupError);
}

TEST(TrainingSet, WritesImageAndMaskPairsWithTextPixels) {
  test::TempDir dir;
  ScenarioConfig c = small_config();
  const auto summary = generate_training_set(c, dir.path().string(), 12, null_logger());
  EXPECT_EQ(summary.frames, 12u);
  int with_text = 0;
  for (int i = 0; i < 12; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%06d", i);
    const cv::Mat image =
        cv::imread((dir.path() / "images" / (std::string(name) + ".jpg")).string());
    const cv::Mat mask = cv::imread((dir.path() / "masks" / (std::string(name) + ".png")).string(),
                                    cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty());
    ASSERT_EQ(mask.type(), CV_8UC1);
    ASSERT_EQ(mask.size(), image.size());
    const int text = cv::countNonZero(mask);
    EXPECT_LT(text, mask.total() / 2) << "text cannot cover most of a street view";
    with_text += text > 50;
  }
  EXPECT_GE(with_text, 3);
}

}  // namespace
}  // namespace keyfleet::scenario
