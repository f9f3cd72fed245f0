#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/scenario/scenario_config.hpp"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <thread>

#include "keyfleet/common/error.hpp"
#include "keyfleet/scenario/camera_effects.hpp"
#include "keyfleet/scenario/flight.hpp"

namespace keyfleet::scenario {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr double kMinVisiblePixels = 12;

std::string frame_name(std::uint64_t index, const std::string& ext) {
  char name[32];
  std::snprintf(name, sizeof name, "%06llu.%s", static_cast<unsigned long long>(index),
                ext.c_str());
  return name;
}

// Where the optical axis meets a facade (or, looking along the street, a point 30 m ahead).
Eigen::Vector3d looked_at(const CameraPose& pose, double half_width) {
  const Eigen::Vector3d centre = pose.centre();
  const Eigen::Vector3d axis = pose.rotation_cw.transpose().col(2);
  if (std::abs(axis.y()) > 1e-6) {
    const double s = ((axis.y() > 0 ? half_width : -half_width) - centre.y()) / axis.y();
    if (s > 0 && s < 200) return centre + axis * s;
  }
  return centre + axis * 30.0;
}

// Image motion of the looked-at point during the exposure: the linear blur it causes.
void motion_blur(const PlaneRenderer& renderer, const Flight& flight, double t, double exposure_s,
                 double half_width, double& length_px, double& angle_deg) {
  length_px = 0, angle_deg = 0;
  if (exposure_s <= 0) return;
  const Eigen::Vector3d point = looked_at(flight.pose_at(t), half_width);
  cv::Point2d start, end;
  if (!renderer.project(flight.pose_at(t - exposure_s / 2), point, start) ||
      !renderer.project(flight.pose_at(t + exposure_s / 2), point, end))
    return;
  const cv::Point2d d = end - start;
  length_px = std::hypot(d.x, d.y);
  angle_deg = std::atan2(d.y, d.x) * 180 / kPi;
}

std::uint64_t folder_bytes(const fs::path& folder) {
  std::uint64_t bytes = 0;
  for (const auto& entry : fs::recursive_directory_iterator(folder))
    if (entry.is_regular_file()) bytes += entry.file_size();
  return bytes;
}

// Saves a frame as JPEG (at `jpeg_quality`) or PNG, by the path's extension.
void save_image(const fs::path& path, const cv::Mat& image, int jpeg_quality) {
  std::vector<int> params;
  if (path.extension() == ".jpg") params = {cv::IMWRITE_JPEG_QUALITY, jpeg_quality};
  if (!cv::imwrite(path.string(), image, params))
    throw std::runtime_error("cannot write " + path.string());
}

void write_drone(const ScenarioConfig& config, const StreetWorld& world, const DroneInfo& drone,
                 std::uint64_t drone_seed, const fs::path& folder) {
  std::mt19937_64 rng(drone_seed);
  const Flight flight(config.drones, drone.day, config.seed, rng);
  const PlaneRenderer renderer(drone.camera);
  const DayLighting lighting = day_lighting(world, drone.day, config.seed);
  CameraEffects effects(config.camera, {drone.camera.width, drone.camera.height}, config.fps,
                        rng());
  fs::create_directories(folder / "frames");
  std::ofstream truth(folder / "truth.jsonl");
  std::ofstream tum(folder / "poses_tum.txt");
  tum << "# timestamp tx ty tz qx qy qz qw (camera-to-world, metres; keyfleet scenario)\n"
      << std::fixed << std::setprecision(6);
  const double exposure_s = config.camera.shutter_fraction / config.fps;
  for (std::uint64_t i = 0; i < drone.frames; ++i) {
    const double t = double(i) / config.fps;
    const CameraPose pose = flight.pose_at(t);
    const RenderedView view = renderer.render(world, pose, lighting);
    FrameTruth frame;
    frame.index = i;
    frame.timestamp_ns = std::int64_t(std::llround(t * 1e9));
    frame.image = "frames/" + frame_name(i, config.image_format);
    frame.camera_to_world = flight.camera_to_world(t);
    motion_blur(renderer, flight, t, exposure_s, world.width_m / 2, frame.motion_blur_px,
                frame.motion_blur_angle_deg);
    frame.shake_burst = flight.in_shake_burst(t);
    AppliedEffects applied;
    const cv::Mat image =
        effects.apply(view.radiance, frame.motion_blur_px, frame.motion_blur_angle_deg, applied);
    frame.exposure_gain = applied.exposure_gain;
    frame.exposure_event = applied.exposure_event;
    frame.mean_level = applied.mean_level;
    const Eigen::Vector3d target = looked_at(pose, world.width_m / 2);
    frame.street_position_m = target.x();
    frame.place_id = world.place_of(target.x());
    frame.words = words_in_view(world, renderer, pose, view.plane_id);
    save_image(folder / frame.image, image, config.image_quality);
    truth << frame_truth_line(frame) << '\n';
    const Pose& p = frame.camera_to_world;
    tum << t << ' ' << p.tx << ' ' << p.ty << ' ' << p.tz << ' ' << p.qx << ' ' << p.qy << ' '
        << p.qz << ' ' << p.qw << '\n';
  }
  if (!truth || !tum)
    throw std::runtime_error("cannot write the truth files in " + folder.string());
}

}  // namespace

CameraModel camera_model(const ScenarioConfig& config) {
  CameraModel camera;
  camera.width = config.width;
  camera.height = config.height;
  camera.fx = camera.fy =
      config.width / 2.0 / std::tan(config.camera.horizontal_fov_deg * kPi / 360.0);
  camera.cx = (config.width - 1) / 2.0;
  camera.cy = (config.height - 1) / 2.0;
  return camera;
}

std::vector<WordInView> words_in_view(const StreetWorld& world, const PlaneRenderer& renderer,
                                      const CameraPose& pose, const cv::Mat& plane_id) {
  const cv::Rect frame(0, 0, plane_id.cols, plane_id.rows);
  const std::vector<cv::Point2f> frame_corners = {{0, 0},
                                                  {float(frame.width), 0},
                                                  {float(frame.width), float(frame.height)},
                                                  {0, float(frame.height)}};
  std::vector<WordInView> words;
  for (const auto& placed : world.words) {
    std::vector<cv::Point2f> quad;
    bool in_front = true;
    for (const auto& corner : placed.truth.word_corners) {
      cv::Point2d pixel;
      in_front = in_front && renderer.project(pose, {corner.x, corner.y, corner.z}, pixel);
      quad.emplace_back(float(pixel.x), float(pixel.y));
    }
    if (!in_front) continue;
    const double area = std::abs(cv::contourArea(quad));
    if (area < kMinVisiblePixels) continue;
    std::vector<cv::Point2f> inside;
    const double area_in_frame = cv::intersectConvexConvex(quad, frame_corners, inside, true);
    if (area_in_frame < 1) continue;
    const cv::Rect box = cv::boundingRect(quad) & frame;
    if (box.area() == 0) continue;
    cv::Mat mask = cv::Mat::zeros(box.size(), CV_8UC1);
    std::vector<cv::Point> local;
    for (const auto& p : quad) local.emplace_back(cvRound(p.x) - box.x, cvRound(p.y) - box.y);
    cv::fillConvexPoly(mask, local, 255);
    const double visible = cv::countNonZero(mask & (plane_id(box) == placed.plane_id));
    if (visible < kMinVisiblePixels) continue;
    WordInView word;
    word.sign_id = placed.truth.id;
    word.text = placed.truth.text;
    word.legible = placed.truth.legible;
    for (std::size_t i = 0; i < 4; ++i) word.quad[i] = {quad[i].x, quad[i].y};
    word.box_x0 = box.x, word.box_y0 = box.y;
    word.box_x1 = box.x + box.width, word.box_y1 = box.y + box.height;
    word.visible_fraction = std::min(1.0, visible / area);
    word.place_id = placed.truth.place_id;
    if (area_in_frame < 0.98 * area)
      word.visibility = WordVisibility::kCut;
    else if (visible < 0.9 * area_in_frame)
      word.visibility = WordVisibility::kOccluded;
    else
      word.visibility = WordVisibility::kFull;
    words.push_back(word);
  }
  return words;
}

GenerationSummary generate_scenario(const ScenarioConfig& config, const std::string& out_dir,
                                    Logger logger, unsigned threads) {
  const auto started = std::chrono::steady_clock::now();
  const fs::path root(out_dir);
  if (fs::exists(root / "scenario.json"))
    throw StartupError(out_dir + ": already holds a scenario; choose a new --out folder");
  fs::create_directories(root);

  std::mt19937_64 rng(config.seed);
  const StreetWorld world = build_street(config, rng);
  logger->info("street of {} m: {} planes, {} words; {} drone(s) x {} frames", world.length_m,
               world.planes.size(), world.words.size(), config.drones.count,
               config.frames_per_drone);

  GenerationSummary summary;
  Scenario& scenario = summary.scenario;
  scenario.name = config.name;
  scenario.seed = config.seed;
  scenario.street_length_m = world.length_m;
  scenario.street_width_m = world.width_m;
  scenario.place_length_m = world.place_length_m;
  scenario.config_yaml = to_yaml(config);
  for (const auto& word : world.words) scenario.signs.push_back(word.truth);
  std::vector<std::uint64_t> drone_seeds;
  for (int i = 0; i < config.drones.count; ++i) {
    DroneInfo drone;
    drone.robot_id = "drone_" + std::to_string(i);
    drone.day = i % config.drones.days;
    drone.folder = drone.robot_id;
    drone.frames = config.frames_per_drone;
    drone.fps = config.fps;
    drone.camera = camera_model(config);
    scenario.drones.push_back(drone);
    drone_seeds.push_back(rng());
  }

  // Each drone depends only on the world and its own seed: the order of work is free.
  const int previous_cv_threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const unsigned workers =
      std::max(1u, std::min<unsigned>(threads ? threads : std::thread::hardware_concurrency(),
                                      unsigned(config.drones.count)));
  std::atomic<int> next{0};
  std::mutex failure_mutex;
  std::string failure;
  std::vector<std::thread> pool;
  for (unsigned w = 0; w < workers; ++w)
    pool.emplace_back([&] {
      for (int i = next++; i < config.drones.count; i = next++) {
        try {
          write_drone(config, world, scenario.drones[std::size_t(i)], drone_seeds[std::size_t(i)],
                      root / scenario.drones[std::size_t(i)].folder);
          logger->info("{}: {} frames written", scenario.drones[std::size_t(i)].robot_id,
                       config.frames_per_drone);
        } catch (const std::exception& e) {
          std::lock_guard<std::mutex> lock(failure_mutex);
          failure = e.what();
        }
      }
    });
  for (auto& t : pool) t.join();
  cv::setNumThreads(previous_cv_threads);
  if (!failure.empty()) throw std::runtime_error("scenario generation failed: " + failure);

  write_scenario(scenario, root.string());
  summary.frames = config.frames_per_drone * std::uint64_t(config.drones.count);
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  summary.bytes_on_disk = folder_bytes(root);
  return summary;
}

GenerationSummary generate_training_set(const ScenarioConfig& config, const std::string& out_dir,
                                        std::uint64_t count, Logger logger) {
  const auto started = std::chrono::steady_clock::now();
  const fs::path root(out_dir);
  fs::create_directories(root / "images");
  fs::create_directories(root / "masks");
  constexpr std::uint64_t kViewsPerStreet = 150;
  GenerationSummary summary;
  const CameraModel camera = camera_model(config);
  const PlaneRenderer renderer(camera);
  std::mt19937_64 rng(config.seed);
  std::uniform_real_distribution<double> unit(0, 1);
  StreetWorld world;
  for (std::uint64_t i = 0; i < count; ++i) {
    if (i % kViewsPerStreet == 0) {
      world = build_street(config, rng);
      logger->info("training views {}..{}: new street with {} words", i,
                   std::min(count, i + kViewsPerStreet) - 1, world.words.size());
    }
    // A random drone viewpoint: anywhere along the street, looking at either side.
    ScenarioConfig view = config;
    view.drones.start_m = unit(rng) * (world.length_m - 10) + 2;
    view.drones.speed_mps = 0.01, view.drones.speed_jitter_mps = 0;
    view.drones.altitude_m = 1.5 + unit(rng) * 6;
    view.drones.lateral_offset_m = (unit(rng) - 0.5) * (world.width_m - 6);
    view.drones.view_yaw_deg = (unit(rng) < 0.5 ? 1 : -1) * (25 + unit(rng) * 70);
    view.drones.pitch_deg = -10 + unit(rng) * 30;
    const Flight flight(view.drones, int(i % 4), config.seed + i, rng);
    const double t = unit(rng) * 30;
    const CameraPose pose = flight.pose_at(t);
    const RenderedView rendered =
        renderer.render(world, pose, day_lighting(world, int(i % 7), config.seed + i));
    CameraEffectsConfig effects_config = config.camera;
    effects_config.exposure_event_rate_hz = 0;
    CameraEffects effects(effects_config, {camera.width, camera.height}, config.fps, rng());
    AppliedEffects applied;
    const double blur = unit(rng) < 0.6 ? unit(rng) * 2 : unit(rng) * 12;
    const cv::Mat image = effects.apply(rendered.radiance, blur, unit(rng) * 180, applied);
    save_image(root / "images" / frame_name(i, "jpg"), image, config.image_quality);
    cv::imwrite((root / "masks" / frame_name(i, "png")).string(), rendered.text_mask);
  }
  summary.frames = count;
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  summary.bytes_on_disk = folder_bytes(root);
  return summary;
}

}  // namespace keyfleet::scenario
