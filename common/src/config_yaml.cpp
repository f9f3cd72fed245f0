// The visitors' machinery (config_yaml.hpp): the reader, the checks every library's
// descriptions use, the file helpers and the reference tables. The descriptions themselves live
// with their structs: shared_config_yaml.cpp (the settings both sides read), and the vision,
// agent, text, places and station libraries' *_config_yaml.cpp.
#include "keyfleet/common/config_yaml.hpp"

#include <filesystem>
#include <fstream>
#include <regex>

#include "keyfleet/common/config.hpp"

namespace keyfleet {

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
const std::set<std::string> kLogLevels = {"trace", "debug", "info", "warn", "error"};

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

std::string markdown_cell(const std::string& text) {
  std::string out;
  for (char ch : text) out += ch == '|' ? std::string("\\|") : std::string(1, ch);
  return out;
}

std::string config_reference_table(const std::string& title, const std::string& intro,
                                   const std::vector<ConfigKey>& keys) {
  std::ostringstream out;
  out << "### " << title << "\n\n"
      << intro << "\n\n"
      << "| key | type | default | allowed |\n|---|---|---|---|\n";
  for (const ConfigKey& key : keys)
    out << "| `" << key.path << "` | " << markdown_cell(key.type) << " | `"
        << markdown_cell(key.default_value) << "` | " << markdown_cell(key.allowed) << " |\n";
  return out.str();
}

}  // namespace keyfleet
