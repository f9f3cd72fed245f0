#pragma once
// How configuration structs meet YAML. Each struct is described once by a visit() function in
// the library that owns the struct; a ConfigReader visitor loads and validates it, a
// ConfigWriter visitor prints it. The libraries of the tools (scenario, mission, eval) describe
// their own structs with these visitors and reuse the descriptions of the agent's and the
// station's structs declared below.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/config_error.hpp"

namespace keyfleet {

// The YAML names of an enum's values: specialise with a `kAll` array of {value, name} pairs.
template <class E>
struct EnumNames;

// "a|b|c"
template <class E>
std::string enum_choices() {
  std::string out;
  for (const auto& [value, name] : EnumNames<E>::kAll) {
    (void)value;
    out += out.empty() ? name : std::string("|") + name;
  }
  return out;
}

template <class E>
std::optional<E> enum_from_name(const std::string& text) {
  for (const auto& [value, name] : EnumNames<E>::kAll)
    if (text == name) return value;
  return std::nullopt;
}

template <class E>
std::string enum_name(E value) {
  for (const auto& [v, name] : EnumNames<E>::kAll)
    if (v == value) return name;
  return "?";
}

// A check returns an empty string when the value is allowed, else what is allowed.
template <class T>
using Check = std::function<std::string(const T&)>;

template <class T>
Check<T> at_least(T low) {
  return [low](const T& v) {
    std::ostringstream msg;
    // Written so that NaN fails: it compares false with everything.
    if (!(v >= low)) msg << "must be >= " << low;
    return msg.str();
  };
}
template <class T>
Check<T> between(T low, T high) {
  return [low, high](const T& v) {
    std::ostringstream msg;
    if (!(v >= low && v <= high)) msg << "must be between " << low << " and " << high;
    return msg.str();
  };
}
Check<double> positive();
Check<std::string> one_of(std::set<std::string> allowed);
// A name that becomes part of a file or folder name: [A-Za-z0-9_.-]{1,max_length}.
Check<std::string> file_name_check(int max_length);
Check<std::string> robot_id_check();
extern const std::set<std::string> kLogLevels;

template <class T>
struct IsVector : std::false_type {};
template <class T>
struct IsVector<std::vector<T>> : std::true_type {};
template <class T>
struct IsStructVector : std::false_type {};
template <class T>
struct IsStructVector<std::vector<T>>
    : std::bool_constant<std::is_class_v<T> && !std::is_same_v<T, std::string>> {};

class ConfigReader {
 public:
  ConfigReader(YAML::Node node, std::string origin, std::string path);

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
    ConfigReader nested(child, origin_, join(key));
    visit(nested, sub);
    nested.finish();
  }

  // Unknown keys are errors that list the allowed ones.
  void finish() const;

  [[noreturn]] void fail(const YAML::Node& at, const std::string& where,
                         const std::string& problem) const;

 private:
  std::string path_or_top() const;
  std::string join(const char* key) const;
  static std::string scalar_text(const YAML::Node& n);

  template <class T>
  T convert(const YAML::Node& child, const std::string& where) const {
    if constexpr (std::is_enum_v<T>) {
      const std::string text = convert<std::string>(child, where);
      if (const auto value = enum_from_name<T>(text)) return *value;
      fail(child, where, "must be one of " + enum_choices<T>() + " (got '" + text + "')");
    } else if constexpr (IsVector<T>::value) {
      if (!child.IsSequence()) fail(child, where, "expected a list");
      T out;
      for (const auto& item : child) {
        using Item = typename T::value_type;
        if constexpr (std::is_class_v<Item> && !std::is_same_v<Item, std::string>) {
          ConfigReader nested(item, origin_, where);
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
      T value{};
      try {
        value = child.as<T>();
      } catch (const YAML::Exception&) {
        fail(child, where,
             std::string("expected ") + type_name<T>() + " (got " + scalar_text(child) + ")");
      }
      // NaN and the infinities are no setting's value: a wait of .inf never ends, and .nan
      // compares false with every bound.
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(value))
          fail(child, where, "must be a finite number (got " + scalar_text(child) + ")");
      }
      return value;
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

class ConfigWriter {
 public:
  explicit ConfigWriter(YAML::Node node) : node_(std::move(node)) {}

  template <class T, class C = std::nullptr_t>
  void field(const char* key, const T& value, C = nullptr) {
    if constexpr (std::is_enum_v<T>) {
      node_[key] = enum_name(value);
    } else if constexpr (IsStructVector<T>::value) {
      YAML::Node list(YAML::NodeType::Sequence);
      for (auto element : value) {
        YAML::Node child(YAML::NodeType::Map);
        ConfigWriter nested(child);
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
    ConfigWriter nested(child);
    visit(nested, sub);
    node_[key] = child;
  }

 private:
  YAML::Node node_;
};

// The descriptions of the structs that the tools' configs embed (defined and instantiated for
// both visitors in config_yaml.cpp).
template <class V>
void visit(V& v, AgentConfig& c);
template <class V>
void visit(V& v, StationConfig& c);
template <class V>
void visit(V& v, SelectorConfig& c);
template <class V>
void visit(V& v, CodecConfig& c);
template <class V>
void visit(V& v, TextReadingConfig& c);

// Cross-field rules that a single key cannot express; throw ConfigError naming `origin`.
void validate(const AgentConfig& config, const std::string& origin);
void validate(const StationConfig& config, const std::string& origin);

// The text of a config file; ConfigError when it cannot be read.
std::string read_config_file(const std::string& path);
YAML::Node parse_yaml(const std::string& text, const std::string& origin);
// A relative path in a config file is relative to the file's folder.
void resolve_relative_to(const std::string& config_path, std::string& path);

// Reads every key of `Config` (unknown keys are errors), without the cross-field checks.
template <class Config>
Config read_config(const std::string& text, const std::string& origin) {
  Config config;
  ConfigReader reader(parse_yaml(text, origin), origin, "");
  visit(reader, config);
  reader.finish();
  return config;
}

template <class Config>
Config parse_config(const std::string& text, const std::string& origin) {
  Config config = read_config<Config>(text, origin);
  validate(config, origin);
  return config;
}

template <class Config>
std::string emit_config(const Config& config) {
  Config copy = config;
  YAML::Node root(YAML::NodeType::Map);
  ConfigWriter writer(root);
  visit(writer, copy);
  YAML::Emitter out;
  out << root;
  return out.c_str();
}

}  // namespace keyfleet
