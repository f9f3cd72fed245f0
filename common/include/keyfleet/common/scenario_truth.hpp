#pragma once
// The generated-scenario format (version 1): what `keyfleet scenario generate` writes and
// what agents, tests, training and evaluation read back.
//
//   <dir>/scenario.json          street, signs, drones (this header's Scenario)
//   <dir>/<robot>/frames/NNNNNN.jpg|png
//   <dir>/<robot>/truth.jsonl    one FrameTruth per line, in frame order
//   <dir>/<robot>/poses_tum.txt  timestamp tx ty tz qx qy qz qw (camera-to-world, TUM)
//
// World frame: x along the street (flight direction), y to the left, z up; metres.
// Camera frame: OpenCV (x right, y down, z forward).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace keyfleet::scenario {

inline constexpr int kFormatVersion = 1;

enum class WordVisibility {
  kFull,      // wholly inside the frame and at least 90 % of it unoccluded
  kCut,       // partly outside the frame
  kOccluded,  // inside the frame, more than 10 % hidden by something nearer
};

const char* to_string(WordVisibility visibility);

struct Point2 {
  double x = 0, y = 0;
};
struct Point3 {
  double x = 0, y = 0, z = 0;
};

struct WordInView {
  int sign_id = 0;  // index into Scenario::signs
  std::string text;
  bool legible = true;         // false for words carried over as illegible ('###') from photos
  std::array<Point2, 4> quad;  // pixel corners: top-left, top-right, bottom-right, bottom-left
  double box_x0 = 0, box_y0 = 0, box_x1 = 0, box_y1 = 0;  // axis-aligned, clipped to frame
  WordVisibility visibility = WordVisibility::kFull;
  double visible_fraction = 1;  // of the whole word area, seen in this frame
  int place_id = 0;
};

struct FrameTruth {
  std::uint64_t index = 0;
  std::int64_t timestamp_ns = 0;
  std::string image;  // path relative to the drone folder
  Pose camera_to_world;
  double motion_blur_px = 0;         // length of the linear blur kernel applied
  double motion_blur_angle_deg = 0;  // its direction in the image (0 = +x)
  bool shake_burst = false;
  double exposure_gain = 1;      // final gain applied to the scene radiance
  std::string exposure_event;    // "", "over" or "under"
  double mean_level = 0;         // mean grey level of the saved frame
  int place_id = 0;              // of the street point the optical axis meets
  double street_position_m = 0;  // x of that point
  std::vector<WordInView> words;
};

struct CameraModel {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

struct SignTruth {
  int id = 0;
  std::string text;
  bool legible = true;
  int place_id = 0;
  std::string side;                    // "left" | "right"
  std::array<Point3, 4> word_corners;  // the word's box in the world
};

struct DroneInfo {
  std::string robot_id;
  int day = 0;
  std::string folder;  // relative to the scenario folder
  std::uint64_t frames = 0;
  double fps = 0;
  CameraModel camera;
};

struct Scenario {
  int format_version = kFormatVersion;
  std::string name;
  std::uint64_t seed = 0;
  double street_length_m = 0;
  double street_width_m = 0;
  double place_length_m = 0;
  std::vector<SignTruth> signs;
  std::vector<DroneInfo> drones;
  std::string config_yaml;  // the generator's effective configuration
};

// Reading throws std::runtime_error naming the file (and line) that is wrong.
Scenario read_scenario(const std::string& scenario_dir);
std::vector<FrameTruth> read_frame_truth(const std::string& drone_dir);

void write_scenario(const Scenario& scenario, const std::string& scenario_dir);
std::string frame_truth_line(const FrameTruth& frame);  // one JSON line, no newline

}  // namespace keyfleet::scenario
