// The YAML descriptions of the agent's settings (agent_config.hpp): one per struct, used by the
// reader, the writer and the reference; the cross-field checks and the loaders.
#include "keyfleet/agent/agent_config_yaml.hpp"

#include "keyfleet/common/shared_config_yaml.hpp"
#include "keyfleet/vision/semantic_config_yaml.hpp"

namespace keyfleet {

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
      {TriggerConfig::Kind::kKlt, "klt"},
      {TriggerConfig::Kind::kStride, "stride"},
      {TriggerConfig::Kind::kList, "list"}};
};

std::optional<SelectorConfig::Strategy> selection_strategy(const std::string& name) {
  return enum_from_name<SelectorConfig::Strategy>(name);
}
std::string selection_strategy_choices() { return enum_choices<SelectorConfig::Strategy>(); }
std::string to_string(SelectorConfig::Strategy strategy) { return enum_name(strategy); }
std::optional<TriggerConfig::Kind> trigger_kind(const std::string& name) {
  return enum_from_name<TriggerConfig::Kind>(name);
}
std::string trigger_kind_choices() { return enum_choices<TriggerConfig::Kind>(); }
std::string to_string(TriggerConfig::Kind kind) { return enum_name(kind); }

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
void visit(V& v, TextRegionsConfig& c) {
  v.field("enabled", c.enabled);
  v.field("max_regions", c.max_regions, between(0, 1000));
  v.field("min_area_px", c.min_area_px, between(0, 1 << 26));
  v.field("merge_gap", c.merge_gap, between(0.0, 100.0));
  v.field("min_line_overlap", c.min_line_overlap, between(0.0, 1.0));
}

// libjpeg's DCT scaling: 1/1, 1/2, 1/4, 1/8.
Check<int> decode_reduce_check() {
  return Check<int>(
      [](const int& v) {
        return v == 1 || v == 2 || v == 4 || v == 8 ? std::string()
                                                    : std::string("must be 1, 2, 4 or 8");
      },
      "1, 2, 4 or 8");
}

template <class V>
void visit(V& v, SelectorConfig& c) {
  v.field("strategy", c.strategy);
  v.field("density", c.density, between(1, 1000));
  v.field("max_window_frames", c.max_window_frames, between(1, 10000));
  v.field("max_scored", c.max_scored, between(0, 10000));
  v.field("decode_reduce", c.decode_reduce, decode_reduce_check());
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
  v.field("text_aware", c.text_aware);
  v.field("text_margin_px", c.text_margin_px, between(0, 256));
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

template void visit(ConfigReader&, AgentConfig&);
template void visit(ConfigWriter&, AgentConfig&);
template void visit(ConfigReference&, AgentConfig&);
template void visit(ConfigReader&, SelectorConfig&);
template void visit(ConfigWriter&, SelectorConfig&);
template void visit(ConfigReference&, SelectorConfig&);
template void visit(ConfigReader&, CodecConfig&);
template void visit(ConfigWriter&, CodecConfig&);
template void visit(ConfigReference&, CodecConfig&);

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

AgentConfig parse_agent_config(const std::string& text, const std::string& origin) {
  return parse_config<AgentConfig>(text, origin);
}
AgentConfig load_agent_config(const std::string& path) {
  AgentConfig config = parse_agent_config(read_config_file(path), path);
  resolve_relative_to(path, config.dds.security.directory);
  return config;
}
std::string to_yaml(const AgentConfig& config) { return emit_config(config); }

}  // namespace keyfleet
