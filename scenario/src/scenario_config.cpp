#include "keyfleet/scenario/scenario_config.hpp"

#include <filesystem>

#include "keyfleet/common/config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, StreetConfig& c) {
  v.field("length_m", c.length_m, between(20.0, 10000.0));
  v.field("width_m", c.width_m, between(4.0, 200.0));
  v.field("facade_height_m", c.facade_height_m, between(2.0, 200.0));
  v.field("building_min_width_m", c.building_min_width_m, between(1.0, 500.0));
  v.field("building_max_width_m", c.building_max_width_m, between(1.0, 500.0));
  v.field("sign_probability", c.sign_probability, between(0.0, 1.0));
  v.field("extra_sign_probability", c.extra_sign_probability, between(0.0, 1.0));
  v.field("place_length_m", c.place_length_m, between(0.5, 1000.0));
  v.field("pole_spacing_m", c.pole_spacing_m, at_least(0.0));
  v.field("tree_spacing_m", c.tree_spacing_m, at_least(0.0));
}

template <class V>
void visit(V& v, TextureConfig& c) {
  v.field("photo_folders", c.photo_folders);
  v.field("optional_photo_folders", c.optional_photo_folders);
  v.field("max_photos", c.max_photos, between(0, 100000));
  v.field("photo_probability", c.photo_probability, between(0.0, 1.0));
  v.field("font_folders", c.font_folders);
  v.field("word_list", c.word_list);
}

template <class V>
void visit(V& v, DroneFlightConfig& c) {
  v.field("count", c.count, between(1, 64));
  v.field("days", c.days, between(1, 16));
  v.field("speed_mps", c.speed_mps, between(0.01, 100.0));
  v.field("speed_jitter_mps", c.speed_jitter_mps, at_least(0.0));
  v.field("start_m", c.start_m, at_least(0.0));
  v.field("altitude_m", c.altitude_m, between(0.2, 500.0));
  v.field("altitude_jitter_m", c.altitude_jitter_m, at_least(0.0));
  v.field("lateral_offset_m", c.lateral_offset_m);
  v.field("lateral_jitter_m", c.lateral_jitter_m, at_least(0.0));
  v.field("view_yaw_deg", c.view_yaw_deg, between(-180.0, 180.0));
  v.field("pitch_deg", c.pitch_deg, between(-89.0, 89.0));
  v.field("heading_jitter_deg", c.heading_jitter_deg, between(0.0, 45.0));
  v.field("shake_deg", c.shake_deg, between(0.0, 20.0));
  v.field("shake_burst_rate_hz", c.shake_burst_rate_hz, at_least(0.0));
  v.field("shake_burst_deg", c.shake_burst_deg, between(0.0, 30.0));
  v.field("shake_burst_s", c.shake_burst_s, between(0.01, 60.0));
}

template <class V>
void visit(V& v, CameraEffectsConfig& c) {
  v.field("horizontal_fov_deg", c.horizontal_fov_deg, between(10.0, 150.0));
  v.field("shutter_fraction", c.shutter_fraction, between(0.0, 1.0));
  v.field("noise_sigma", c.noise_sigma, between(0.0, 100.0));
  v.field("shot_noise", c.shot_noise, between(0.0, 10.0));
  v.field("vignetting", c.vignetting, between(0.0, 1.0));
  v.field("auto_exposure_lag_s", c.auto_exposure_lag_s, between(0.0, 60.0));
  v.field("exposure_event_rate_hz", c.exposure_event_rate_hz, at_least(0.0));
  v.field("exposure_event_s", c.exposure_event_s, between(0.01, 60.0));
  v.field("over_exposure_gain", c.over_exposure_gain, between(1.0, 20.0));
  v.field("under_exposure_gain", c.under_exposure_gain, between(0.01, 1.0));
  v.field("greyscale", c.greyscale);
  v.field("jpeg_artifact_quality", c.jpeg_artifact_quality, between(0, 100));
}

template <class V>
void visit(V& v, ScenarioConfig& c) {
  v.field("name", c.name, file_name_check(64));
  v.field("seed", c.seed);
  v.field("frames_per_drone", c.frames_per_drone, at_least<std::uint64_t>(1));
  v.field("fps", c.fps, between(0.1, 1000.0));
  v.field("width", c.width, between(32, 8192));
  v.field("height", c.height, between(32, 8192));
  v.field("image_format", c.image_format, one_of({"jpg", "png"}));
  v.field("image_quality", c.image_quality, between(1, 100));
  v.section("street", c.street);
  v.section("textures", c.textures);
  v.section("drones", c.drones);
  v.section("camera", c.camera);
}

template void visit(ConfigReader&, ScenarioConfig&);
template void visit(ConfigWriter&, ScenarioConfig&);

void validate(const ScenarioConfig& c, const std::string& origin) {
  if (c.street.building_min_width_m > c.street.building_max_width_m)
    throw ConfigError(origin +
                      ": street.building_min_width_m: must not exceed "
                      "building_max_width_m");
  const double flight_m = c.drones.start_m + (c.drones.speed_mps + c.drones.speed_jitter_mps) *
                                                 static_cast<double>(c.frames_per_drone) / c.fps;
  if (flight_m > c.street.length_m)
    throw ConfigError(origin + ": drones.speed_mps: flights of " +
                      std::to_string(static_cast<int>(flight_m)) +
                      " m would leave the street (street.length_m " +
                      std::to_string(static_cast<int>(c.street.length_m)) +
                      "): lower the speed or frames_per_drone, or lengthen the street");
  for (const auto& folder : c.textures.photo_folders)
    if (!std::filesystem::is_directory(folder))
      throw ConfigError(origin + ": textures.photo_folders: '" + folder + "' is not a folder");
  if (!c.textures.word_list.empty() && !std::filesystem::is_regular_file(c.textures.word_list))
    throw ConfigError(origin + ": textures.word_list: '" + c.textures.word_list +
                      "' does not exist");
}

ScenarioConfig parse_scenario_config(const std::string& text, const std::string& origin) {
  return parse_config<ScenarioConfig>(text, origin);
}

ScenarioConfig load_scenario_config(const std::string& path) {
  // Relative paths are resolved against the file before the checks that look at them.
  ScenarioConfig config = read_config<ScenarioConfig>(read_config_file(path), path);
  for (auto& folder : config.textures.photo_folders) resolve_relative_to(path, folder);
  for (auto& folder : config.textures.optional_photo_folders) resolve_relative_to(path, folder);
  resolve_relative_to(path, config.textures.word_list);
  validate(config, path);
  return config;
}

std::string to_yaml(const ScenarioConfig& config) { return emit_config(config); }

}  // namespace keyfleet
