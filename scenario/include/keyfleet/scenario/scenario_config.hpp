#pragma once
// The scenario generator's settings, loaded from YAML by scenario_config.cpp.
#include <cstdint>
#include <string>
#include <vector>

namespace keyfleet {

// The scenario generator (`keyfleet scenario generate`): a street with shop signs, drones
// flying along it on two 'days', camera effects with known parameters. Lengths in metres,
// angles in degrees, times in seconds.
struct StreetConfig {
  double length_m = 160.0;
  double width_m = 16.0;  // facade to facade
  double facade_height_m = 12.0;
  double building_min_width_m = 6.0;
  double building_max_width_m = 14.0;
  double sign_probability = 0.85;       // chance that a building carries a shop sign
  double extra_sign_probability = 0.4;  // chance of a second, smaller sign
  double place_length_m = 5.0;          // place ids bin the street in segments this long
  double pole_spacing_m = 14.0;         // lamp posts along the kerbs (occluders); 0 = none
  double tree_spacing_m = 22.0;         // trees along the kerbs (occluders); 0 = none
};

struct TextureConfig {
  std::vector<std::string> photo_folders;           // real photos for facades (must exist)
  std::vector<std::string> optional_photo_folders;  // used when present, else skipped
  // Paths in a scenario file are relative to that file. Without photos, facades are procedural.
  int max_photos = 60;             // at most this many photos are loaded
  double photo_probability = 0.5;  // chance that a facade uses a photo when available
  std::vector<std::string> font_folders = {"/usr/share/fonts/truetype",
                                           "/usr/share/fonts/opentype"};
  std::string word_list;  // one word a line; empty = the built-in shop words
};

struct DroneFlightConfig {
  int count = 3;
  int days = 2;  // drone i flies on day i % days
  double speed_mps = 2.0;
  double speed_jitter_mps = 0.3;  // per drone
  double start_m = 8.0;           // where along the street the flights begin
  double altitude_m = 5.0;
  double altitude_jitter_m = 1.0;  // per drone and day
  double lateral_offset_m = -1.0;  // from the street centre, + toward the left facade
  double lateral_jitter_m = 1.5;
  double view_yaw_deg = 55.0;         // camera yaw from the flight direction, toward the left
  double pitch_deg = 8.0;             // camera pitch, + up
  double heading_jitter_deg = 4.0;    // slow yaw wander
  double shake_deg = 0.25;            // continuous high-frequency shake
  double shake_burst_rate_hz = 0.08;  // random bursts of strong shake
  double shake_burst_deg = 2.0;
  double shake_burst_s = 0.6;
};

struct CameraEffectsConfig {
  double horizontal_fov_deg = 70.0;
  double shutter_fraction = 0.5;         // exposure time / frame period (sets motion blur)
  double noise_sigma = 2.0;              // read noise, grey levels
  double shot_noise = 0.4;               // photon noise scale: sigma = shot_noise * sqrt(level)
  double vignetting = 0.25;              // brightness loss at the corners
  double auto_exposure_lag_s = 0.6;      // time constant of the auto-exposure
  double exposure_event_rate_hz = 0.06;  // random over/under-exposure events
  double exposure_event_s = 0.5;
  double over_exposure_gain = 2.4;
  double under_exposure_gain = 0.35;
  bool greyscale = false;
  int jpeg_artifact_quality = 0;  // re-encode at this JPEG quality before saving; 0 = off
};

struct ScenarioConfig {
  std::string name = "street";
  std::uint64_t seed = 1;
  std::uint64_t frames_per_drone = 600;
  double fps = 30.0;
  int width = 640;
  int height = 480;
  std::string image_format = "jpg";  // jpg | png
  int image_quality = 92;            // jpg quality of the saved frames
  StreetConfig street;
  TextureConfig textures;
  DroneFlightConfig drones;
  CameraEffectsConfig camera;
};

// Paths in a scenario file are resolved against its folder. Loaders throw ConfigError naming
// the file, the key and what is allowed.
ScenarioConfig load_scenario_config(const std::string& path);
ScenarioConfig parse_scenario_config(const std::string& text, const std::string& origin);
std::string to_yaml(const ScenarioConfig& config);

// The description of the struct for the other configs that embed a scenario.
template <class V>
void visit(V& v, ScenarioConfig& c);
void validate(const ScenarioConfig& config, const std::string& origin);

}  // namespace keyfleet
