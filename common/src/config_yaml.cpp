// The YAML descriptions of the agent's and the station's configuration structs; the
// visitors, checks and helpers they use are in config_yaml.hpp.
#include "keyfleet/common/config_yaml.hpp"

#include <filesystem>
#include <fstream>
#include <regex>

namespace keyfleet {

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
struct EnumNames<VerifierKind> {
  static constexpr std::pair<VerifierKind, const char*> kAll[] = {
      {VerifierKind::kVfc, "vfc"},
      {VerifierKind::kRansacHomography, "ransac_homography"},
      {VerifierKind::kRansacFundamental, "ransac_fundamental"}};
};
template <>
struct EnumNames<PlaceRetrieval> {
  static constexpr std::pair<PlaceRetrieval, const char*> kAll[] = {
      {PlaceRetrieval::kBow, "bow"},
      {PlaceRetrieval::kCnn, "cnn"},
      {PlaceRetrieval::kFusion, "fusion"}};
};
template <>
struct EnumNames<TriggerConfig::Kind> {
  static constexpr std::pair<TriggerConfig::Kind, const char*> kAll[] = {
      {TriggerConfig::Kind::kOrbSlam, "orbslam"},
      {TriggerConfig::Kind::kKlt, "klt"},
      {TriggerConfig::Kind::kStride, "stride"},
      {TriggerConfig::Kind::kList, "list"}};
};

// --- Checks and helpers --------------------------------------------------------------------

Check<double> positive() {
  return Check<double>(
      [](const double& v) { return v > 0 ? std::string() : std::string("must be > 0"); }, "> 0");
}
Check<std::string> one_of(std::set<std::string> allowed) {
  std::string names;
  for (const auto& a : allowed) names += names.empty() ? a : ", " + a;
  return Check<std::string>(
      [allowed](const std::string& v) {
        if (allowed.count(v)) return std::string();
        std::string list;
        for (const auto& a : allowed) list += list.empty() ? a : "|" + a;
        return "must be one of " + list;
      },
      "one of " + names);
}
Check<std::string> robot_id_check() {
  return Check<std::string>(
      [](const std::string& v) {
        return is_valid_robot_id(v) ? std::string() : std::string("must match [A-Za-z0-9_-]{1,32}");
      },
      "[A-Za-z0-9_-]{1,32}");
}
Check<std::string> file_name_check(int max_length) {
  const std::string pattern = "[A-Za-z0-9_.-]{1," + std::to_string(max_length) + "}";
  return Check<std::string>(
      [pattern](const std::string& v) {
        return std::regex_match(v, std::regex(pattern)) ? std::string() : "must match " + pattern;
      },
      pattern);
}
// "WxH", both sides positive multiples of 32 up to 4096 (the converted detectors' input sizes).
static Check<std::string> detector_size_check() {
  return Check<std::string>(
      [](const std::string& v) {
        std::smatch m;
        const std::string rule = "must be auto or WxH, sides multiples of 32 from 32 to 4096";
        if (v == "auto") return std::string();
        if (!std::regex_match(v, m, std::regex("([0-9]{1,4})x([0-9]{1,4})"))) return rule;
        for (int i = 1; i <= 2; ++i) {
          const int side = std::stoi(m[i].str());
          if (side < 32 || side > 4096 || side % 32 != 0) return rule;
        }
        return std::string();
      },
      "auto or WxH, sides multiples of 32 from 32 to 4096");
}
const std::set<std::string> kLogLevels = {"trace", "debug", "info", "warn", "error"};

std::optional<SelectorConfig::Strategy> selection_strategy(const std::string& name) {
  return enum_from_name<SelectorConfig::Strategy>(name);
}
std::string selection_strategy_choices() { return enum_choices<SelectorConfig::Strategy>(); }
std::string to_string(SelectorConfig::Strategy strategy) { return enum_name(strategy); }
std::optional<VerifierKind> verifier_kind(const std::string& name) {
  return enum_from_name<VerifierKind>(name);
}
std::string verifier_kind_choices() { return enum_choices<VerifierKind>(); }
std::optional<PlaceRetrieval> place_retrieval(const std::string& name) {
  return enum_from_name<PlaceRetrieval>(name);
}
std::string place_retrieval_choices() { return enum_choices<PlaceRetrieval>(); }
std::string to_string(PlaceRetrieval retrieval) { return enum_name(retrieval); }
std::optional<TriggerConfig::Kind> trigger_kind(const std::string& name) {
  return enum_from_name<TriggerConfig::Kind>(name);
}
std::string trigger_kind_choices() { return enum_choices<TriggerConfig::Kind>(); }
std::string to_string(TriggerConfig::Kind kind) { return enum_name(kind); }

ConfigReader::ConfigReader(YAML::Node node, std::string origin, std::string path)
    : node_(std::move(node)), origin_(std::move(origin)), path_(std::move(path)) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) fail(node_, path_or_top(), "expected a mapping");
}

void ConfigReader::finish() const {
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

void ConfigReader::fail(const YAML::Node& at, const std::string& where,
                        const std::string& problem) const {
  std::ostringstream msg;
  msg << origin_;
  if (at.Mark().line >= 0) msg << ":" << at.Mark().line + 1;
  msg << ": " << where << ": " << problem;
  throw ConfigError(msg.str());
}

std::string ConfigReader::path_or_top() const { return path_.empty() ? "(top level)" : path_; }

std::string ConfigReader::join(const char* key) const {
  return path_.empty() ? key : path_ + "." + key;
}

std::string ConfigReader::scalar_text(const YAML::Node& n) {
  return n.IsScalar() ? "'" + n.Scalar() + "'" : "a non-scalar";
}

YAML::Node parse_yaml(const std::string& text, const std::string& origin) {
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(origin + ":" + std::to_string(e.mark.line + 1) +
                      ": not valid YAML: " + e.msg);
  }
}

std::string read_config_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot read config file (missing or unreadable)");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void resolve_relative_to(const std::string& config_path, std::string& path) {
  if (!path.empty() && std::filesystem::path(path).is_relative())
    path = (std::filesystem::path(config_path).parent_path() / path).lexically_normal().string();
}

// --- The descriptions: one per struct, used by both visitors. -------------------------

template <class V>
void visit(V& v, DdsSecurity& c) {
  v.field("enabled", c.enabled);
  v.field("directory", c.directory);
}

template <class V>
void visit(V& v, DdsLinkProfile& c) {
  v.field("rate_kbit_s", c.rate_kbit_s, between(0.0, 10000000.0));
  v.field("mtu_bytes", c.mtu_bytes, between(576, 65535));
  v.field("pacing", c.pacing, between(0.1, 1.0));
  v.field("announcement_period_s", c.announcement_period_s, positive());
  v.field("lease_duration_s", c.lease_duration_s, positive());
  v.field("rejoin_after_s", c.rejoin_after_s, between(0.0, 86400.0));
}

template <class V>
void visit(V& v, DdsSettings& c) {
  v.field("domain_id", c.domain_id, between(0, 232));
  v.field("partition", c.partition,
          Check<std::string>(
              [](const std::string& s) {
                return s.empty() ? std::string("must not be empty") : std::string();
              },
              "not empty"));
  v.field("transport", c.transport);
  v.field("initial_peers", c.initial_peers);
  v.field("shared_memory", c.shared_memory);
  v.field("lease_duration_s", c.lease_duration_s, positive());
  v.field("announcement_period_s", c.announcement_period_s, positive());
  v.field("keyframe_history_depth", c.keyframe_history_depth, between(1, 1000));
  v.field("heartbeat_period_s", c.heartbeat_period_s, positive());
  v.field("max_bytes_per_s", c.max_bytes_per_s, between<std::uint64_t>(0, 100000000000ULL));
  v.section("link", c.link);
  v.section("security", c.security);
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
void visit(V& v, KltConfig& c) {
  v.field("max_points", c.max_points, between(16, 20000));
  v.field("cell_px", c.cell_px, between(4, 1000));
  v.field("fast_threshold", c.fast_threshold, between(1, 255));
  v.field("window_px", c.window_px, between(5, 101));
  v.field("pyramid_levels", c.pyramid_levels, between(1, 8));
  v.field("iterations", c.iterations, between(1, 100));
  v.field("max_error", c.max_error, between(1.0, 255.0));
  v.field("border_px", c.border_px, between(0, 1000));
  v.field("ref_ratio", c.ref_ratio, between(0.1, 1.0));
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
  v.section("klt", c.klt);
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
  v.field("bfloat16", c.bfloat16);
}

template <class V>
void visit(V& v, TextRegionsConfig& c) {
  v.field("enabled", c.enabled);
  v.field("max_regions", c.max_regions, between(0, 1000));
  v.field("min_area_px", c.min_area_px, between(0, 1 << 26));
  v.field("merge_gap", c.merge_gap, between(0.0, 100.0));
  v.field("min_line_overlap", c.min_line_overlap, between(0.0, 1.0));
}

template <class V>
void visit(V& v, SelectorConfig& c) {
  v.field("strategy", c.strategy);
  v.field("density", c.density, between(1, 1000));
  v.field("max_window_frames", c.max_window_frames, between(1, 10000));
  v.section("trigger", c.trigger);
  v.section("quality", c.quality);
  v.section("semantic", c.semantic);
  v.section("text_regions", c.text_regions);
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
void visit(V& v, LinkAdaptationConfig& c) {
  v.field("enabled", c.enabled);
  v.field("latency_target_s", c.latency_target_s, between(0.1, 3600.0));
  v.field("jpeg_qualities", c.jpeg_qualities,
          Check<std::vector<int>>(
              [](const std::vector<int>& qualities) {
                for (std::size_t i = 0; i < qualities.size(); ++i) {
                  if (qualities[i] < 1 || qualities[i] > 100) return std::string("must be 1..100");
                  if (i > 0 && qualities[i] >= qualities[i - 1]) return std::string("must fall");
                }
                return std::string();
              },
              "falling, each 1..100"));
  v.field("scales", c.scales,
          Check<std::vector<double>>(
              [](const std::vector<double>& scales) {
                for (std::size_t i = 0; i < scales.size(); ++i) {
                  if (!(scales[i] >= 0.1 && scales[i] < 1.0))
                    return std::string("must be at least 0.1 and below 1");
                  if (i > 0 && scales[i] >= scales[i - 1]) return std::string("must fall");
                }
                return std::string();
              },
              "falling, each in [0.1, 1)"));
  v.field("max_density", c.max_density, between(1, 16));
  v.field("utilisation", c.utilisation, between(0.1, 1.0));
  v.field("raise_after_s", c.raise_after_s, between(0.0, 3600.0));
  v.field("estimator_window_s", c.estimator_window_s, between(0.5, 3600.0));
}

template <class V>
void visit(V& v, AgentConfig& c) {
  v.field("robot_id", c.robot_id, robot_id_check());
  v.section("source", c.source);
  v.section("selector", c.selector);
  v.section("codec", c.codec);
  v.section("ledger", c.ledger);
  v.section("outbox", c.outbox);
  v.section("link_adaptation", c.link_adaptation);
  v.section("dds", c.dds);
  v.field("stats_period_s", c.stats_period_s, positive());
  v.field("wait_for_station_s", c.wait_for_station_s, at_least(0.0));
  v.field("drain_timeout_s", c.drain_timeout_s, at_least(0.0));
  v.field("linger_s", c.linger_s, between(0.0, 3600.0));
  v.field("log_level", c.log_level, one_of(kLogLevels));
}

template <class V>
void visit(V& v, StationLimits& c) {
  using L = StationLimits;
  v.field("max_image_bytes", c.max_image_bytes, between<std::uint64_t>(1, L::kCapImageBytes));
  v.field("max_width", c.max_width, between<std::uint32_t>(1, L::kCapSide));
  v.field("max_height", c.max_height, between<std::uint32_t>(1, L::kCapSide));
  v.field("max_pixels", c.max_pixels, between<std::uint64_t>(1, L::kCapPixels));
  v.field("max_scans", c.max_scans, between(1, L::kCapScans));
  v.field("max_pixels_per_byte", c.max_pixels_per_byte, between(1.0, L::kCapPixelsPerByte));
  v.field("max_text_regions", c.max_text_regions, between(0, 100000));
  v.field("allowed_robots", c.allowed_robots);
  v.field("max_robots", c.max_robots, between(1, L::kCapRobots));
}

template <class V>
void visit(V& v, TextReadingConfig& c) {
  v.field("enabled", c.enabled);
  v.field("engine", c.engine);
  v.field("tessdata_dir", c.tesseract.tessdata_dir);
  v.field("language", c.tesseract.language);
  v.field("thresholding_method", c.tesseract.thresholding_method, between(0, 2));
  v.field("min_confidence", c.min_confidence, between(0.0, 1.0));
  v.field("min_word_length", c.min_word_length, between(1, 64));
  v.field("min_word_height", c.min_word_height, between(0, 8192));
  v.field("min_long_side", c.min_long_side, between(0, 8192));
  v.field("max_long_side", c.max_long_side, between(0, 16384));
  v.field("segmenter_model", c.mininet.segmenter_model);
  v.field("segmenter_widths", c.mininet.segmenter_widths);
  v.field("threads", c.threads, between(0, 64));
  v.field("region_padding", c.mininet.region_padding, between(0.0, 4.0));
  v.field("region_line_height", c.tesseract.line_height, between(8, 1024));
  v.field("max_regions", c.max_regions, between(1, 10000));
  v.field("cut_word_margin", c.ppocr.cut_word_margin, between(-1, 1000));
  v.field("region_hints", c.ppocr.region_hints, one_of({"off", "only", "first"}));
  v.field("region_hint_detector_size", c.ppocr.region_hint_detector_size, detector_size_check());
  v.field("region_hint_padding", c.ppocr.region_hint_padding, between(0.0, 4.0));
  v.field("ppocr_models", c.ppocr.models);
  v.field("ppocr_detector_size", c.ppocr.detector_size, detector_size_check());
  v.field("ppocr_binary_threshold", c.ppocr.binary_threshold, between(0.0, 1.0));
  v.field("ppocr_box_threshold", c.ppocr.box_threshold, between(0.0, 1.0));
  v.field("ppocr_unclip_ratio", c.ppocr.unclip_ratio, between(0.0, 10.0));
  v.field("ppocr_latin_only", c.ppocr.latin_only);
  v.field("ppocr_space_probability", c.ppocr.space_probability, between(0.0, 1.0));
  v.field("lexicon", c.lexicon);
}

template <class V>
void visit(V& v, PlaceRecognitionConfig& c) {
  v.field("enabled", c.enabled);
  v.field("vocabulary", c.vocabulary);
  v.field("retrieval", c.retrieval);
  v.field("descriptor", c.descriptor);
  v.field("fusion_depth", c.fusion_depth, between(1, 1000));
  v.field("orb_features", c.orb_features, between(100, 20000));
  v.field("candidates", c.candidates, between(1, 100));
  v.field("min_inliers", c.min_inliers, between(4, 100000));
  v.field("min_inlier_ratio", c.min_inlier_ratio, between(0.0, 1.0));
  v.field("verifier", c.verifier);
  v.field("same_robot_exclusion_s", c.same_robot_exclusion_s, between(0.0, 1e6));
}

template <class V>
void visit(V& v, AnalysisConfig& c) {
  v.field("workers", c.workers, between(1, 64));
  v.field("queue_capacity", c.queue_capacity, between(1, 100000));
  v.field("drain_timeout_s", c.drain_timeout_s, between(0.0, 3600.0));
  v.field("max_attempts", c.max_attempts, between(1, 1000));
  v.section("text", c.text);
  v.section("places", c.places);
}

template <class V>
void visit(V& v, DashboardConfig& c) {
  v.field("enabled", c.enabled);
  v.field("address", c.address);
  v.field("port", c.port, between(0, 65535));
  v.field("token", c.token);
  v.field("update_period_s", c.update_period_s, between(0.05, 60.0));
  v.field("thumbnails_per_robot", c.thumbnails_per_robot, between(1, 1000));
  v.field("threads", c.threads, between(1, 64));
  v.field("max_connections", c.max_connections, between(4, 4096));
  v.field("max_connections_per_client", c.max_connections_per_client, between(1, 4096));
  v.field("max_event_streams", c.max_event_streams, between(0, 1024));
  v.field("request_timeout_s", c.request_timeout_s, between(0.1, 300.0));
}

template <class V>
void visit(V& v, StationConfig& c) {
  v.section("dds", c.dds);
  v.section("limits", c.limits);
  v.section("analysis", c.analysis);
  v.section("dashboard", c.dashboard);
  v.field("database", c.database);
  v.field("mission_log", c.mission_log);
  v.field("report_period_s", c.report_period_s, positive());
  v.field("report_reserve_bytes", c.report_reserve_bytes, between<std::uint64_t>(0, 1ULL << 30));
  v.field("log_level", c.log_level, one_of(kLogLevels));
}

template void visit(ConfigReader&, AgentConfig&);
template void visit(ConfigWriter&, AgentConfig&);
template void visit(ConfigReader&, StationConfig&);
template void visit(ConfigWriter&, StationConfig&);
template void visit(ConfigReader&, SelectorConfig&);
template void visit(ConfigWriter&, SelectorConfig&);
template void visit(ConfigReader&, CodecConfig&);
template void visit(ConfigWriter&, CodecConfig&);
template void visit(ConfigReader&, TextReadingConfig&);
template void visit(ConfigWriter&, TextReadingConfig&);
template void visit(ConfigReference&, AgentConfig&);
template void visit(ConfigReference&, StationConfig&);
template void visit(ConfigReference&, SelectorConfig&);
template void visit(ConfigReference&, CodecConfig&);
template void visit(ConfigReference&, TextReadingConfig&);

namespace {
std::string markdown_cell(const std::string& text) {
  std::string out;
  for (char ch : text) out += ch == '|' ? std::string("\\|") : std::string(1, ch);
  return out;
}

template <class Config>
std::string reference_table(const std::string& title, const std::string& intro) {
  std::vector<ConfigKey> keys;
  Config defaults;
  ConfigReference reference(keys, "");
  visit(reference, defaults);
  std::ostringstream out;
  out << "### " << title << "\n\n"
      << intro << "\n\n"
      << "| key | type | default | allowed |\n|---|---|---|---|\n";
  for (const ConfigKey& key : keys)
    out << "| `" << key.path << "` | " << markdown_cell(key.type) << " | `"
        << markdown_cell(key.default_value) << "` | " << markdown_cell(key.allowed) << " |\n";
  return out.str();
}
}  // namespace

std::string config_reference_markdown() {
  return reference_table<AgentConfig>(
             "Agent",
             "`robot_agent --config FILE` (`configs/agent.yaml`), and `agent:` in a "
             "mission file: `AgentConfig`.") +
         "\n" +
         reference_table<StationConfig>(
             "Station",
             "`ground_station --config FILE` (`configs/station.yaml`), and `station:` "
             "in a mission file: `StationConfig`.");
}

void validate(const DdsSettings& dds, const std::string& origin) {
  if (dds.security.enabled && dds.security.directory.empty())
    throw ConfigError(origin + ": dds.security.directory: required when dds.security.enabled");
}

void validate(const AgentConfig& c, const std::string& origin) {
  validate(c.dds, origin);
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

void validate(const StationConfig& c, const std::string& origin) {
  validate(c.dds, origin);
  for (const std::string& id : c.limits.allowed_robots)
    if (!is_valid_robot_id(id))
      throw ConfigError(origin + ": limits.allowed_robots: '" + id +
                        "' is not a robot id ([A-Za-z0-9_-]{1,32})");
  if (c.limits.allowed_robots.size() > static_cast<std::size_t>(c.limits.max_robots))
    throw ConfigError(
        origin + ": limits.allowed_robots: " + std::to_string(c.limits.allowed_robots.size()) +
        " robots, more than limits.max_robots (" + std::to_string(c.limits.max_robots) + ")");
  const DashboardConfig& d = c.dashboard;
  if (!d.token.empty() && d.token.size() < DashboardConfig::kMinTokenLength)
    throw ConfigError(origin + ": dashboard.token: " + std::to_string(d.token.size()) +
                      " characters, fewer than " +
                      std::to_string(DashboardConfig::kMinTokenLength) +
                      ": leave it out off loopback and the station generates a strong one");
  if (d.max_connections_per_client > d.max_connections || d.max_event_streams >= d.max_connections)
    throw ConfigError(origin + ": dashboard: max_connections_per_client (" +
                      std::to_string(d.max_connections_per_client) + ") and max_event_streams (" +
                      std::to_string(d.max_event_streams) +
                      ") must leave room within max_connections (" +
                      std::to_string(d.max_connections) + ")");
}

bool is_loopback_address(const std::string& address) {
  static const std::regex ipv4_loopback("127\\.[0-9]{1,3}\\.[0-9]{1,3}\\.[0-9]{1,3}");
  return address == "localhost" || address == "::1" || std::regex_match(address, ipv4_loopback);
}

bool is_valid_robot_id(const std::string& robot_id) {
  static const std::regex pattern("[A-Za-z0-9_-]{1,32}");
  return std::regex_match(robot_id, pattern);
}

AgentConfig parse_agent_config(const std::string& text, const std::string& origin) {
  return parse_config<AgentConfig>(text, origin);
}
StationConfig parse_station_config(const std::string& text, const std::string& origin) {
  return parse_config<StationConfig>(text, origin);
}
AgentConfig load_agent_config(const std::string& path) {
  AgentConfig config = parse_agent_config(read_config_file(path), path);
  resolve_relative_to(path, config.dds.security.directory);
  return config;
}
StationConfig load_station_config(const std::string& path) {
  StationConfig config = parse_station_config(read_config_file(path), path);
  resolve_relative_to(path, config.dds.security.directory);
  return config;
}
std::string to_yaml(const AgentConfig& config) { return emit_config(config); }
std::string to_yaml(const StationConfig& config) { return emit_config(config); }

}  // namespace keyfleet
