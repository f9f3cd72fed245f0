#include "keyfleet/eval/eval_config.hpp"

#include <set>

#include "keyfleet/agent/agent_config_yaml.hpp"
#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"
#include "keyfleet/station/text/text_reading_config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, EvalEncoding& c) {
  v.field("name", c.name, file_name_check(32));
  v.field("jpeg_quality", c.jpeg_quality, between(1, 100));
  v.field("scale", c.scale,
          Check<double>(
              [](double s) {
                return s > 0 && s <= 1 ? std::string() : std::string("must be in (0, 1]");
              },
              "(0, 1]"));
  v.field("text_aware", c.text_aware);
}

template <class V>
void visit(V& v, EvalConfig& c) {
  v.section("scenario", c.scenario);
  v.field("scenario_dir", c.scenario_dir);
  v.field("strategies", c.strategies,
          Check<std::vector<std::string>>([](const std::vector<std::string>& names) {
            for (const auto& name : names)
              if (!selection_strategy(name))
                return "each must be one of " + selection_strategy_choices();
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
  v.field("encodings", c.encodings,
          Check<std::vector<EvalEncoding>>(
              [](const std::vector<EvalEncoding>& list) {
                std::set<std::string> names;
                for (const auto& e : list) {
                  if (e.name.empty()) return std::string("each needs a name");
                  if (!names.insert(e.name).second)
                    return "names must be unique ('" + e.name + "' twice)";
                }
                return std::string();
              },
              "names given and unique"));
  v.field("text_margin_px", c.text_margin_px, between(0, 1000));
  v.field("vocabulary", c.vocabulary);
  v.field("orb_features", c.orb_features, between(100, 20000));
  v.field("place_retrievals", c.place_retrievals,
          Check<std::vector<std::string>>([](const std::vector<std::string>& names) {
            for (const auto& name : names)
              if (!place_retrieval(name)) return "each must be one of " + place_retrieval_choices();
            return names.empty() ? std::string("must not be empty") : std::string();
          }));
  v.field("place_descriptor", c.place_descriptor);
  v.field("query_every", c.query_every, between(1, 100000));
  v.field("place_tolerance_m", c.place_tolerance_m, between(0.01, 10000.0));
  v.field("ocr_threads", c.ocr_threads, between(1, 64));
  v.section("text", c.text);
}

// The scenario is only generated (and so only checked) when no scenario_dir is given.
void validate(const EvalConfig& c, const std::string& origin) {
  if (c.scenario_dir.empty()) validate(c.scenario, origin + " (scenario)");
}

EvalConfig parse_eval_config(const std::string& text, const std::string& origin) {
  return parse_config<EvalConfig>(text, origin);
}

EvalConfig load_eval_config(const std::string& path) {
  EvalConfig config = read_config<EvalConfig>(read_config_file(path), path);
  resolve_relative_to(path, config.scenario_dir);
  for (auto& folder : config.scenario.textures.photo_folders) resolve_relative_to(path, folder);
  for (auto& folder : config.scenario.textures.optional_photo_folders)
    resolve_relative_to(path, folder);
  resolve_relative_to(path, config.scenario.textures.word_list);
  validate(config, path);
  return config;
}

std::string to_yaml(const EvalConfig& config) { return emit_config(config); }

}  // namespace keyfleet
