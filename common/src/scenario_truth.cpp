#include "keyfleet/common/scenario_truth.hpp"

#include <nlohmann/json.hpp>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/json_integer.hpp"

namespace keyfleet::scenario {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// One path component of letters, digits, '_', '-' and '.', neither "." nor "..".
bool is_plain_folder_name(const std::string& name) {
  if (name.empty() || name == "." || name == ".." || name.size() > 255) return false;
  for (const char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
      return false;
  return true;
}

const char* const kVisibilityNames[] = {"full", "cut", "occluded"};

WordVisibility visibility_from(const std::string& name) {
  for (int i = 0; i < 3; ++i)
    if (name == kVisibilityNames[i]) return static_cast<WordVisibility>(i);
  throw std::runtime_error("unknown word visibility '" + name + "'");
}

json to_json(const Pose& p) { return json::array({p.tx, p.ty, p.tz, p.qx, p.qy, p.qz, p.qw}); }

Pose pose_from(const json& j) {
  return Pose{j.at(0), j.at(1), j.at(2), j.at(3), j.at(4), j.at(5), j.at(6)};
}

json to_json(const WordInView& w) {
  json quad = json::array();
  for (const auto& p : w.quad) quad.push_back({p.x, p.y});
  return {{"sign", w.sign_id},
          {"text", w.text},
          {"legible", w.legible},
          {"quad", quad},
          {"box", {w.box_x0, w.box_y0, w.box_x1, w.box_y1}},
          {"visibility", to_string(w.visibility)},
          {"visible_fraction", w.visible_fraction},
          {"place", w.place_id}};
}

WordInView word_from(const json& j) {
  WordInView w;
  w.sign_id = json_integer<int>(j.at("sign"));
  w.text = j.at("text");
  w.legible = j.at("legible");
  for (std::size_t i = 0; i < 4; ++i)
    w.quad[i] = {j.at("quad").at(i).at(0), j.at("quad").at(i).at(1)};
  const auto& box = j.at("box");
  w.box_x0 = box.at(0), w.box_y0 = box.at(1), w.box_x1 = box.at(2), w.box_y1 = box.at(3);
  w.visibility = visibility_from(j.at("visibility"));
  w.visible_fraction = j.at("visible_fraction");
  w.place_id = json_integer<int>(j.at("place"));
  return w;
}

FrameTruth frame_from(const json& j) {
  FrameTruth f;
  f.index = json_integer<std::uint64_t>(j.at("index"));
  f.timestamp_ns = json_integer<std::int64_t>(j.at("timestamp_ns"));
  f.image = j.at("image");
  f.camera_to_world = pose_from(j.at("camera_to_world"));
  f.motion_blur_px = j.at("motion_blur_px");
  f.motion_blur_angle_deg = j.at("motion_blur_angle_deg");
  f.shake_burst = j.at("shake_burst");
  f.exposure_gain = j.at("exposure_gain");
  f.exposure_event = j.at("exposure_event");
  f.mean_level = j.at("mean_level");
  f.place_id = json_integer<int>(j.at("place"));
  f.street_position_m = j.at("street_position_m");
  for (const auto& w : j.at("words")) f.words.push_back(word_from(w));
  return f;
}

}  // namespace

const char* to_string(WordVisibility visibility) {
  return kVisibilityNames[static_cast<int>(visibility)];
}

std::string frame_truth_line(const FrameTruth& f) {
  json words = json::array();
  for (const auto& w : f.words) words.push_back(to_json(w));
  const json j = {{"index", f.index},
                  {"timestamp_ns", f.timestamp_ns},
                  {"image", f.image},
                  {"camera_to_world", to_json(f.camera_to_world)},
                  {"motion_blur_px", f.motion_blur_px},
                  {"motion_blur_angle_deg", f.motion_blur_angle_deg},
                  {"shake_burst", f.shake_burst},
                  {"exposure_gain", f.exposure_gain},
                  {"exposure_event", f.exposure_event},
                  {"mean_level", f.mean_level},
                  {"place", f.place_id},
                  {"street_position_m", f.street_position_m},
                  {"words", words}};
  return j.dump();
}

void write_scenario(const Scenario& s, const std::string& scenario_dir) {
  json signs = json::array();
  for (const auto& sign : s.signs) {
    json corners = json::array();
    for (const auto& c : sign.word_corners) corners.push_back({c.x, c.y, c.z});
    signs.push_back({{"id", sign.id},
                     {"text", sign.text},
                     {"legible", sign.legible},
                     {"place", sign.place_id},
                     {"side", sign.side},
                     {"word_corners", corners}});
  }
  json drones = json::array();
  for (const auto& d : s.drones)
    drones.push_back({{"robot_id", d.robot_id},
                      {"day", d.day},
                      {"folder", d.folder},
                      {"frames", d.frames},
                      {"fps", d.fps},
                      {"camera",
                       {{"width", d.camera.width},
                        {"height", d.camera.height},
                        {"fx", d.camera.fx},
                        {"fy", d.camera.fy},
                        {"cx", d.camera.cx},
                        {"cy", d.camera.cy}}}});
  const json doc = {{"format", "keyfleet-scenario"},
                    {"version", s.format_version},
                    {"name", s.name},
                    {"seed", s.seed},
                    {"street",
                     {{"length_m", s.street_length_m},
                      {"width_m", s.street_width_m},
                      {"place_length_m", s.place_length_m}}},
                    {"signs", signs},
                    {"drones", drones},
                    {"config_yaml", s.config_yaml}};
  const fs::path path = fs::path(scenario_dir) / "scenario.json";
  std::ofstream out(path);
  out << doc.dump(1) << '\n';
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

Scenario read_scenario(const std::string& scenario_dir) {
  const fs::path path = fs::path(scenario_dir) / "scenario.json";
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": no scenario here (missing scenario.json)");
  try {
    const json doc = json::parse(in);
    if (doc.at("format") != "keyfleet-scenario")
      throw std::runtime_error("not a keyfleet scenario");
    Scenario s;
    s.format_version = json_integer<int>(doc.at("version"));
    if (s.format_version != kFormatVersion)
      throw std::runtime_error("format version " + std::to_string(s.format_version) +
                               ", this build reads " + std::to_string(kFormatVersion));
    s.name = doc.at("name");
    s.seed = json_integer<std::uint64_t>(doc.at("seed"));
    s.street_length_m = doc.at("street").at("length_m");
    s.street_width_m = doc.at("street").at("width_m");
    s.place_length_m = doc.at("street").at("place_length_m");
    s.config_yaml = doc.value("config_yaml", "");
    for (const auto& j : doc.at("signs")) {
      SignTruth sign;
      sign.id = json_integer<int>(j.at("id"));
      sign.text = j.at("text");
      sign.legible = j.at("legible");
      sign.place_id = json_integer<int>(j.at("place"));
      sign.side = j.at("side");
      for (std::size_t i = 0; i < 4; ++i) {
        const auto& c = j.at("word_corners").at(i);
        sign.word_corners[i] = {c.at(0), c.at(1), c.at(2)};
      }
      s.signs.push_back(sign);
    }
    for (const auto& j : doc.at("drones")) {
      DroneInfo d;
      d.robot_id = j.at("robot_id");
      d.day = json_integer<int>(j.at("day"));
      d.folder = j.at("folder");
      d.frames = json_integer<std::uint64_t>(j.at("frames"));
      d.fps = j.at("fps");
      const auto& c = j.at("camera");
      d.camera = {json_integer<int>(c.at("width")),
                  json_integer<int>(c.at("height")),
                  c.at("fx"),
                  c.at("fy"),
                  c.at("cx"),
                  c.at("cy")};
      // Both become paths under the run and scenario folders: nothing may climb out of them.
      if (!is_valid_robot_id(d.robot_id))
        throw std::runtime_error("drone robot_id '" + d.robot_id +
                                 "' does not match [A-Za-z0-9_-]{1,32}");
      if (!is_plain_folder_name(d.folder))
        throw std::runtime_error("drone folder '" + d.folder +
                                 "' is not a plain folder name inside the scenario");
      s.drones.push_back(d);
    }
    return s;
  } catch (const json::exception& e) {
    throw std::runtime_error(path.string() + ": malformed scenario: " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

std::vector<FrameTruth> read_frame_truth(const std::string& drone_dir) {
  const fs::path path = fs::path(drone_dir) / "truth.jsonl";
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": missing frame truth");
  std::vector<FrameTruth> frames;
  std::string line;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    try {
      frames.push_back(frame_from(json::parse(line)));
    } catch (const std::exception& e) {
      throw std::runtime_error(path.string() + ":" + std::to_string(number) +
                               ": malformed frame truth: " + e.what());
    }
  }
  return frames;
}

}  // namespace keyfleet::scenario
