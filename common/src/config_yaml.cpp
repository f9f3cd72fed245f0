// The one place where configuration structs meet YAML. Each struct is described once by a
// visit() function; a Reader visitor loads and validates it, a Writer visitor prints it.
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <set>
#include <sstream>
#include <type_traits>
#include <utility>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/config_error.hpp"

namespace keyfleet {
namespace {

template <class E>
struct EnumNames;
template <>
struct EnumNames<DdsSettings::Transport> {
  static constexpr std::pair<DdsSettings::Transport, const char*> kAll[] = {
      {DdsSettings::Transport::kLocalhost, "localhost"},
      {DdsSettings::Transport::kNetwork, "network"}};
};
template <>
struct EnumNames<SourceConfig::Kind> {
  static constexpr std::pair<SourceConfig::Kind, const char*> kAll[] = {
      {SourceConfig::Kind::kGenerated, "generated"},
      {SourceConfig::Kind::kImageFolder, "folder"},
      {SourceConfig::Kind::kVideoFile, "video"},
      {SourceConfig::Kind::kScenario, "scenario"}};
};
template <>
struct EnumNames<SelectorConfig::Strategy> {
  static constexpr std::pair<SelectorConfig::Strategy, const char*> kAll[] = {
      {SelectorConfig::Strategy::kVslam, "vslam"},
      {SelectorConfig::Strategy::kQuality, "quality"},
      {SelectorConfig::Strategy::kSemantic, "semantic"},
      {SelectorConfig::Strategy::kFull, "full"}};
};
template <>
struct EnumNames<TriggerConfig::Kind> {
  static constexpr std::pair<TriggerConfig::Kind, const char*> kAll[] = {
      {TriggerConfig::Kind::kOrbSlam, "orbslam"},
      {TriggerConfig::Kind::kStride, "stride"},
      {TriggerConfig::Kind::kList, "list"}};
};

template <class E>
std::string enum_choices() {
  std::string out;
  for (const auto& [value, name] : EnumNames<E>::kAll) {
    (void)value;
    out += out.empty() ? name : std::string("|") + name;
  }
  return out;
}

// A check returns an empty string when the value is allowed, else what is allowed.
template <class T>
using Check = std::function<std::string(const T&)>;

template <class T>
Check<T> at_least(T low) {
  return [low](const T& v) {
    std::ostringstream msg;
    if (v < low) msg << "must be >= " << low;
    return msg.str();
  };
}
template <class T>
Check<T> between(T low, T high) {
  return [low, high](const T& v) {
    std::ostringstream msg;
    if (v < low || v > high) msg << "must be between " << low << " and " << high;
    return msg.str();
  };
}
Check<double> positive() {
  return [](const double& v) { return v > 0 ? std::string() : std::string("must be > 0"); };
}
Check<std::string> one_of(std::set<std::string> allowed) {
  return [allowed](const std::string& v) {
    if (allowed.count(v)) return std::string();
    std::string list;
    for (const auto& a : allowed) list += list.empty() ? a : "|" + a;
    return "must be one of " + list;
  };
}
Check<std::string> robot_id_check() {
  return [](const std::string& v) {
    return is_valid_robot_id(v) ? std::string() : std::string("must match [A-Za-z0-9_-]{1,32}");
  };
}
// A name that becomes part of a file or folder name: [A-Za-z0-9_.-]{1,max_length}.
Check<std::string> file_name_check(int max_length) {
  const std::string pattern = "[A-Za-z0-9_.-]{1," + std::to_string(max_length) + "}";
  return [pattern](const std::string& v) {
    return std::regex_match(v, std::regex(pattern)) ? std::string() : "must match " + pattern;
  };
}
const std::set<std::string> kLogLevels = {"trace", "debug", "info", "warn", "error"};

template <class T>
struct IsVector : std::false_type {};
template <class T>
struct IsVector<std::vector<T>> : std::true_type {};
template <class T>
struct IsStructVector : std::false_type {};
template <class T>
struct IsStructVector<std::vector<T>>
    : std::bool_constant<std::is_class_v<T> && !std::is_same_v<T, std::string>> {};

class Reader {
 public:
  Reader(YAML::Node node, std::string origin, std::string path)
      : node_(std::move(node)), origin_(std::move(origin)), path_(std::move(path)) {
    if (node_ && !node_.IsNull() && !node_.IsMap())
      fail(node_, path_or_top(), "expected a mapping");
  }

  template <class T>
  void field(const char* key, T& value, Check<T> check = {}) {
    known_.insert(key);
    if (!node_ || node_.IsNull()) return;
    const YAML::Node child = node_[key];
    if (!child) return;
    const std::string where = join(key);
    value = convert<T>(child, where);
    if (check) {
      const std::string problem = check(value);
      if (!problem.empty()) fail(child, where, problem + " (got " + scalar_text(child) + ")");
    }
  }

  template <class T>
  void field(const char* key, std::optional<T>& value, Check<T> check = {}) {
    known_.insert(key);
    if (!node_ || node_.IsNull() || !node_[key]) return;
    T inner{};
    field(key, inner, check);
    value = inner;
  }

  template <class S>
  void section(const char* key, S& sub) {
    known_.insert(key);
    if (!node_ || node_.IsNull()) return;
    const YAML::Node child = node_[key];
    if (!child) return;
    Reader nested(child, origin_, join(key));
    visit(nested, sub);
    nested.finish();
  }

  void finish() const {
    if (!node_ || node_.IsNull()) return;
    for (const auto& entry : node_) {
      if (!entry.first.IsScalar()) fail(entry.first, path_or_top(), "keys must be plain names");
      const std::string key = entry.first.Scalar();
      if (known_.count(key)) continue;
      std::string allowed;
      for (const auto& k : known_) allowed += allowed.empty() ? k : ", " + k;
      fail(entry.first, join(key.c_str()), "unknown key (allowed here: " + allowed + ")");
    }
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& where,
                         const std::string& problem) const {
    std::ostringstream msg;
    msg << origin_;
    if (at.Mark().line >= 0) msg << ":" << at.Mark().line + 1;
    msg << ": " << where << ": " << problem;
    throw ConfigError(msg.str());
  }

 private:
  std::string path_or_top() const { return path_.empty() ? "(top level)" : path_; }

  std::string join(const char* key) const { return path_.empty() ? key : path_ + "." + key; }

  static std::string scalar_text(const YAML::Node& n) {
    return n.IsScalar() ? "'" + n.Scalar() + "'" : "a non-scalar";
  }

  template <class T>
  T convert(const YAML::Node& child, const std::string& where) const {
    if constexpr (std::is_enum_v<T>) {
      const std::string text = convert<std::string>(child, where);
      for (const auto& [value, name] : EnumNames<T>::kAll)
        if (text == name) return value;
      fail(child, where, "must be one of " + enum_choices<T>() + " (got '" + text + "')");
    } else if constexpr (IsVector<T>::value) {
      if (!child.IsSequence()) fail(child, where, "expected a list");
      T out;
      for (const auto& item : child) {
        using Item = typename T::value_type;
        if constexpr (std::is_class_v<Item> && !std::is_same_v<Item, std::string>) {
          Reader nested(item, origin_, where);
          Item element;
          visit(nested, element);
          nested.finish();
          out.push_back(std::move(element));
        } else {
          out.push_back(convert<Item>(item, where));
        }
      }
      return out;
    } else {
      if (!child.IsScalar()) fail(child, where, "expected a single value");
      if constexpr (std::is_unsigned_v<T> && !std::is_same_v<T, bool>) {
        if (!child.Scalar().empty() && child.Scalar()[0] == '-')
          fail(child, where, "must not be negative (got '" + child.Scalar() + "')");
      }
      try {
        return child.as<T>();
      } catch (const YAML::Exception&) {
        fail(child, where,
             std::string("expected ") + type_name<T>() + " (got " + scalar_text(child) + ")");
      }
    }
  }

  template <class T>
  static const char* type_name() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    if constexpr (std::is_integral_v<T>) return "an integer";
    if constexpr (std::is_floating_point_v<T>) return "a number";
    return "a string";
  }

  YAML::Node node_;
  std::string origin_;
  std::string path_;
  std::set<std::string> known_;
};

class Writer {
 public:
  explicit Writer(YAML::Node node) : node_(std::move(node)) {}

  template <class T, class C = std::nullptr_t>
  void field(const char* key, const T& value, C = nullptr) {
    if constexpr (std::is_enum_v<T>) {
      for (const auto& [v, name] : EnumNames<T>::kAll)
        if (v == value) node_[key] = name;
    } else if constexpr (IsStructVector<T>::value) {
      YAML::Node list(YAML::NodeType::Sequence);
      for (auto element : value) {
        YAML::Node child(YAML::NodeType::Map);
        Writer nested(child);
        visit(nested, element);
        list.push_back(child);
      }
      node_[key] = list;
    } else {
      node_[key] = value;
    }
  }
  template <class T, class C = std::nullptr_t>
  void field(const char* key, const std::optional<T>& value, C = nullptr) {
    if (value) field(key, *value);
  }
  template <class S>
  void section(const char* key, S& sub) {
    YAML::Node child(YAML::NodeType::Map);
    Writer nested(child);
    visit(nested, sub);
    node_[key] = child;
  }

 private:
  YAML::Node node_;
};

// --- The descriptions: one per struct, used by both visitors. -------------------------

template <class V>
void visit(V& v, DdsSettings& c) {
  v.field("domain_id", c.domain_id, between(0, 232));
  v.field("partition", c.partition, Check<std::string>([](const std::string& s) {
            return s.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("transport", c.transport);
  v.field("initial_peers", c.initial_peers);
  v.field("shared_memory", c.shared_memory);
  v.field("lease_duration_s", c.lease_duration_s, positive());
  v.field("announcement_period_s", c.announcement_period_s, positive());
  v.field("keyframe_history_depth", c.keyframe_history_depth, between(1, 1000));
  v.field("heartbeat_period_s", c.heartbeat_period_s, positive());
  v.field("max_bytes_per_s", c.max_bytes_per_s, between<std::uint64_t>(0, 100000000000ULL));
}

template <class V>
void visit(V& v, SourceConfig& c) {
  v.field("kind", c.kind);
  v.field("path", c.path);
  v.field("drone", c.drone);
  v.field("fps", c.fps, between(0.1, 1000.0));
  v.field("realtime", c.realtime);
  v.field("max_frames", c.max_frames);
  v.field("width", c.width, between(16, 8192));
  v.field("height", c.height, between(16, 8192));
  v.field("seed", c.seed);
}

template <class V>
void visit(V& v, TriggerConfig& c) {
  v.field("kind", c.kind);
  v.field("stride", c.stride, between(1, 100000));
  v.field("list", c.list);
  v.field("features", c.features, between(50, 20000));
  v.field("levels", c.levels, between(1, 16));
  v.field("scale_factor", c.scale_factor, between(1.05, 2.0));
  v.field("image_scale", c.image_scale, between(0.1, 1.0));
  v.field("max_frames", c.max_frames, between(0, 100000));
  v.field("mapping_busy_frames", c.mapping_busy_frames, between(0, 1000));
  v.field("ref_ratio", c.ref_ratio, between(0.1, 1.0));
  v.field("min_inliers", c.min_inliers, between(8, 10000));
}

template <class V>
void visit(V& v, QualityConfig& c) {
  v.field("size", c.size, between(16, 2048));
  v.field("sharpness_width", c.sharpness_width, between(32, 8192));
  v.field("sharpness_gate", c.sharpness_gate, between(0.0, 1.0));
  v.field("edge_contrast", c.edge_contrast, between(0.0, 2000.0));
  v.field("sharp_ratio", c.sharp_ratio, between(0.0, 4.0));
}

template <class V>
void visit(V& v, SemanticConfig& c) {
  v.field("model", c.model);
  v.field("border", c.border, between(0.0, 0.45));
  v.field("threads", c.threads, between(0, 64));
}

template <class V>
void visit(V& v, SelectorConfig& c) {
  v.field("strategy", c.strategy);
  v.field("density", c.density, between(1, 1000));
  v.field("max_window_frames", c.max_window_frames, between(1, 10000));
  v.section("trigger", c.trigger);
  v.section("quality", c.quality);
  v.section("semantic", c.semantic);
}

template <class V>
void visit(V& v, CodecConfig& c) {
  v.field("jpeg_quality", c.jpeg_quality, between(1, 100));
}

template <class V>
void visit(V& v, LedgerConfig& c) {
  v.field("baseline_sample_every", c.baseline_sample_every, between(1, 100000));
}

template <class V>
void visit(V& v, OutboxConfig& c) {
  v.field("path", c.path);
  v.field("max_pending", c.max_pending, at_least<std::uint64_t>(1));
  v.field("max_age_s", c.max_age_s, between(0.001, 1e8));
  v.field("resend_after_s", c.resend_after_s, between(0.001, 1e6));
  v.field("resend_batch", c.resend_batch, between(1, 100000));
}

template <class V>
void visit(V& v, AgentConfig& c) {
  v.field("robot_id", c.robot_id, robot_id_check());
  v.section("source", c.source);
  v.section("selector", c.selector);
  v.section("codec", c.codec);
  v.section("ledger", c.ledger);
  v.section("outbox", c.outbox);
  v.section("dds", c.dds);
  v.field("stats_period_s", c.stats_period_s, positive());
  v.field("wait_for_station_s", c.wait_for_station_s, at_least(0.0));
  v.field("drain_timeout_s", c.drain_timeout_s, at_least(0.0));
  v.field("log_level", c.log_level, one_of(kLogLevels));
}

template <class V>
void visit(V& v, StationLimits& c) {
  v.field("max_image_bytes", c.max_image_bytes, at_least<std::uint64_t>(1));
  v.field("max_width", c.max_width, at_least<std::uint32_t>(1));
  v.field("max_height", c.max_height, at_least<std::uint32_t>(1));
}

template <class V>
void visit(V& v, TextReadingConfig& c) {
  v.field("enabled", c.enabled);
  v.field("engine", c.engine);
  v.field("tessdata_dir", c.tessdata_dir);
  v.field("language", c.language);
  v.field("min_confidence", c.min_confidence, between(0.0, 1.0));
  v.field("min_long_side", c.min_long_side, between(0, 8192));
  v.field("min_word_length", c.min_word_length, between(1, 64));
}

template <class V>
void visit(V& v, PlaceRecognitionConfig& c) {
  v.field("enabled", c.enabled);
  v.field("vocabulary", c.vocabulary);
  v.field("orb_features", c.orb_features, between(100, 20000));
  v.field("candidates", c.candidates, between(1, 100));
  v.field("min_inliers", c.min_inliers, between(4, 100000));
  v.field("min_inlier_ratio", c.min_inlier_ratio, between(0.0, 1.0));
  v.field("verifier", c.verifier, one_of({"vfc", "ransac_homography", "ransac_fundamental"}));
  v.field("same_robot_exclusion_s", c.same_robot_exclusion_s, between(0.0, 1e6));
}

template <class V>
void visit(V& v, AnalysisConfig& c) {
  v.field("workers", c.workers, between(1, 64));
  v.field("queue_capacity", c.queue_capacity, between(1, 100000));
  v.field("drain_timeout_s", c.drain_timeout_s, between(0.0, 3600.0));
  v.section("text", c.text);
  v.section("places", c.places);
}

template <class V>
void visit(V& v, StationConfig& c) {
  v.section("dds", c.dds);
  v.section("limits", c.limits);
  v.section("analysis", c.analysis);
  v.field("database", c.database);
  v.field("mission_log", c.mission_log);
  v.field("report_period_s", c.report_period_s, positive());
  v.field("log_level", c.log_level, one_of(kLogLevels));
}

template <class V>
void visit(V& v, MissionConfig& c) {
  v.field("name", c.name, file_name_check(64));
  v.field("drones", c.drones, between(1, 64));
  v.field("robot_id_prefix", c.robot_id_prefix);
  v.field("run_root", c.run_root);
  v.field("domain_id", c.domain_id, between(0, 232));
  v.field("agent_timeout_s", c.agent_timeout_s, positive());
  v.field("station_drain_timeout_s", c.station_drain_timeout_s, positive());
  v.field("scenario", c.scenario);
  v.field("scenario_dir", c.scenario_dir);
  v.section("agent", c.agent);
  v.section("station", c.station);
}

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

template <class V>
void visit(V& v, EvalConfig& c) {
  v.section("scenario", c.scenario);
  v.field("scenario_dir", c.scenario_dir);
  v.field("strategies", c.strategies,
          Check<std::vector<std::string>>([](const std::vector<std::string>& names) {
            for (const auto& name : names)
              if (name != "vslam" && name != "quality" && name != "semantic" && name != "full")
                return std::string("each must be vslam, quality, semantic or full");
            return names.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("densities", c.densities, Check<std::vector<double>>([](const std::vector<double>& d) {
            for (double f : d)
              if (!(f > 0 && f <= 1)) return std::string("each must be in (0, 1]");
            return d.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("drones", c.drones);
  v.section("selector", c.selector);
  v.section("codec", c.codec);
  v.field("vocabulary", c.vocabulary);
  v.field("orb_features", c.orb_features, between(100, 20000));
  v.field("query_every", c.query_every, between(1, 100000));
  v.field("place_tolerance_m", c.place_tolerance_m, between(0.01, 10000.0));
  v.field("ocr_threads", c.ocr_threads, between(1, 64));
}

template <class V>
void visit(V& v, LinkProfileConfig& c) {
  v.field("name", c.name, file_name_check(32));
  v.field("rate_kbit_s", c.rate_kbit_s, between(0.0, 1e7));
  v.field("delay_ms", c.delay_ms, between(0.0, 10000.0));
  v.field("loss_percent", c.loss_percent, between(0.0, 100.0));
}

template <class V>
void visit(V& v, BandwidthExperimentConfig& c) {
  v.field("name", c.name);
  v.field("run_root", c.run_root);
  v.field("drones", c.drones, Check<std::vector<int>>([](const std::vector<int>& counts) {
            for (int n : counts)
              if (n < 1 || n > 64) return std::string("every count must be between 1 and 64");
            return counts.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("profiles", c.profiles);
  v.field("links", c.links, Check<std::vector<std::string>>([](const std::vector<std::string>& l) {
            for (const auto& kind : l)
              if (kind != "flow_control" && kind != "netns")
                return std::string("each must be flow_control or netns");
            return l.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("netns_dds_cap_fraction", c.netns_dds_cap_fraction, between(0.0, 1.0));
  v.field("bin_s", c.bin_s, between(0.01, 60.0));
  v.field("python", c.python);
  v.section("mission", c.mission);
}

// Cross-field rules that a single key cannot express.
void validate(const AgentConfig& c, const std::string& origin) {
  const auto strategy = c.selector.strategy;
  const bool needs_model = strategy == SelectorConfig::Strategy::kSemantic ||
                           strategy == SelectorConfig::Strategy::kFull;
  if (needs_model && c.selector.semantic.model.empty())
    throw ConfigError(
        origin + ": selector.semantic.model: required for the " +
        std::string(strategy == SelectorConfig::Strategy::kFull ? "full" : "semantic") +
        " strategy");
  if (c.selector.trigger.kind == TriggerConfig::Kind::kList && c.selector.trigger.list.empty())
    throw ConfigError(origin + ": selector.trigger.list: required when trigger.kind is list");
  const bool needs_path = c.source.kind != SourceConfig::Kind::kGenerated;
  if (needs_path && c.source.path.empty())
    throw ConfigError(origin + ": source.path: required when source.kind is folder or video");
}

void validate(const MissionConfig& c, const std::string& origin) {
  validate(c.agent, origin + " (agent)");
  if (!is_valid_robot_id(c.robot_id_prefix + std::to_string(c.drones - 1)))
    throw ConfigError(origin + ": robot_id_prefix: '" + c.robot_id_prefix +
                      "' does not make valid robot ids ([A-Za-z0-9_-]{1,32})");
}
void validate(const StationConfig&, const std::string&) {}
void validate(const BandwidthExperimentConfig& c, const std::string& origin) {
  validate(c.mission, origin + " (mission)");
  if (c.profiles.empty()) throw ConfigError(origin + ": profiles: must not be empty");
}

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

// The scenario is only generated (and so only checked) when no scenario_dir is given.
void validate(const EvalConfig& c, const std::string& origin) {
  if (c.scenario_dir.empty()) validate(c.scenario, origin + " (scenario)");
}

YAML::Node parse_yaml(const std::string& text, const std::string& origin) {
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(origin + ":" + std::to_string(e.mark.line + 1) +
                      ": not valid YAML: " + e.msg);
  }
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot read config file (missing or unreadable)");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

template <class Config>
Config parse(const std::string& text, const std::string& origin) {
  Config config;
  Reader reader(parse_yaml(text, origin), origin, "");
  visit(reader, config);
  reader.finish();
  validate(config, origin);
  return config;
}

template <class Config>
std::string emit(const Config& config) {
  Config copy = config;
  YAML::Node root(YAML::NodeType::Map);
  Writer writer(root);
  visit(writer, copy);
  YAML::Emitter out;
  out << root;
  return out.c_str();
}

}  // namespace

bool is_valid_robot_id(const std::string& robot_id) {
  static const std::regex pattern("[A-Za-z0-9_-]{1,32}");
  return std::regex_match(robot_id, pattern);
}

AgentConfig parse_agent_config(const std::string& text, const std::string& origin) {
  return parse<AgentConfig>(text, origin);
}
StationConfig parse_station_config(const std::string& text, const std::string& origin) {
  return parse<StationConfig>(text, origin);
}
MissionConfig parse_mission_config(const std::string& text, const std::string& origin) {
  return parse<MissionConfig>(text, origin);
}
ScenarioConfig parse_scenario_config(const std::string& text, const std::string& origin) {
  return parse<ScenarioConfig>(text, origin);
}

AgentConfig load_agent_config(const std::string& path) {
  return parse_agent_config(read_file(path), path);
}
StationConfig load_station_config(const std::string& path) {
  return parse_station_config(read_file(path), path);
}
MissionConfig load_mission_config(const std::string& path) {
  MissionConfig config = parse_mission_config(read_file(path), path);
  // Paths inside a mission file are relative to the file, as a reader would expect.
  const auto base = std::filesystem::path(path).parent_path();
  for (std::string* relative : {&config.scenario, &config.scenario_dir})
    if (!relative->empty() && std::filesystem::path(*relative).is_relative())
      *relative = (base / *relative).lexically_normal().string();
  if (!config.scenario.empty() && !std::filesystem::is_regular_file(config.scenario))
    throw ConfigError(path + ": scenario: '" + config.scenario + "' does not exist");
  if (!config.scenario_dir.empty() && !std::filesystem::is_directory(config.scenario_dir))
    throw ConfigError(path + ": scenario_dir: '" + config.scenario_dir + "' is not a folder");
  return config;
}
ScenarioConfig load_scenario_config(const std::string& path) {
  const std::string text = read_file(path);
  // Resolve relative paths against the file before the checks that look at them.
  ScenarioConfig config;
  Reader reader(parse_yaml(text, path), path, "");
  visit(reader, config);
  reader.finish();
  const auto base = std::filesystem::path(path).parent_path();
  auto resolve = [&](std::string& p) {
    if (!p.empty() && std::filesystem::path(p).is_relative())
      p = (base / p).lexically_normal().string();
  };
  for (auto& folder : config.textures.photo_folders) resolve(folder);
  for (auto& folder : config.textures.optional_photo_folders) resolve(folder);
  resolve(config.textures.word_list);
  validate(config, path);
  return config;
}

EvalConfig parse_eval_config(const std::string& text, const std::string& origin) {
  return parse<EvalConfig>(text, origin);
}
EvalConfig load_eval_config(const std::string& path) {
  EvalConfig config;
  Reader reader(parse_yaml(read_file(path), path), path, "");
  visit(reader, config);
  reader.finish();
  // Paths are relative to the file, as in a scenario file.
  const auto base = std::filesystem::path(path).parent_path();
  auto resolve = [&](std::string& p) {
    if (!p.empty() && std::filesystem::path(p).is_relative())
      p = (base / p).lexically_normal().string();
  };
  resolve(config.scenario_dir);
  for (auto& folder : config.scenario.textures.photo_folders) resolve(folder);
  for (auto& folder : config.scenario.textures.optional_photo_folders) resolve(folder);
  resolve(config.scenario.textures.word_list);
  validate(config, path);
  return config;
}

std::string to_yaml(const AgentConfig& config) { return emit(config); }
std::string to_yaml(const StationConfig& config) { return emit(config); }
std::string to_yaml(const MissionConfig& config) { return emit(config); }
std::string to_yaml(const ScenarioConfig& config) { return emit(config); }
std::string to_yaml(const BandwidthExperimentConfig& config) { return emit(config); }

BandwidthExperimentConfig parse_bandwidth_experiment_config(const std::string& text,
                                                            const std::string& origin) {
  return parse<BandwidthExperimentConfig>(text, origin);
}
BandwidthExperimentConfig load_bandwidth_experiment_config(const std::string& path) {
  return parse_bandwidth_experiment_config(read_file(path), path);
}
std::string to_yaml(const EvalConfig& config) { return emit(config); }

}  // namespace keyfleet
