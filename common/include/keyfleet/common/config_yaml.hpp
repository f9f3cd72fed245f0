#pragma once
// How configuration structs meet YAML. Each struct is described once by a visit() function in
// the library that owns the struct; a ConfigReader visitor loads and validates it, a
// ConfigWriter visitor prints it, a ConfigReference lists its keys. The descriptions live with
// their structs: the settings both sides read in shared_config_yaml.hpp, the agent's in
// agent/agent_config_yaml.hpp, the station's in station/station_config_yaml.hpp, the text
// reader's, place recognition's and the segmenter's in their libraries; the tools' libraries
// (scenario, mission, eval) describe their own structs and reuse those.
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

// A check returns an empty string when the value is allowed, else what is allowed. It may
// carry a short description of what it allows ("0 to 232"), which the configuration reference
// prints; a check without one is listed as "checked".
template <class T>
class Check {
 public:
  Check() = default;
  template <class F, class = std::enable_if_t<!std::is_same_v<std::decay_t<F>, Check> &&
                                              std::is_invocable_r_v<std::string, F, const T&>>>
  Check(F rule, std::string description = {})  // NOLINT: lambdas convert implicitly
      : rule_(std::move(rule)), description_(std::move(description)) {}

  std::string operator()(const T& value) const { return rule_(value); }
  explicit operator bool() const { return static_cast<bool>(rule_); }
  const std::string& description() const { return description_; }

 private:
  std::function<std::string(const T&)> rule_;
  std::string description_;
};

template <class T>
Check<T> at_least(T low) {
  std::ostringstream text;
  text << ">= " << low;
  return Check<T>(
      [low](const T& v) {
        std::ostringstream msg;
        // Written so that NaN fails: it compares false with everything.
        if (!(v >= low)) msg << "must be >= " << low;
        return msg.str();
      },
      text.str());
}
template <class T>
Check<T> between(T low, T high) {
  std::ostringstream text;
  text << low << " to " << high;
  return Check<T>(
      [low, high](const T& v) {
        std::ostringstream msg;
        if (!(v >= low && v <= high)) msg << "must be between " << low << " and " << high;
        return msg.str();
      },
      text.str());
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

// One key of a configuration file, as the configuration reference lists it.
struct ConfigKey {
  std::string path;           // "dds.link.rate_kbit_s"
  std::string type;           // "number", "list of strings", "choice"
  std::string default_value;  // a default-constructed struct's value, as YAML spells it
  std::string allowed;        // what the check allows; empty when the key has none
};

// The third visitor: lists every key of a struct (default-constructed by the caller) with its
// type, its default and what its check allows, for `keyfleet config reference`.
class ConfigReference {
 public:
  ConfigReference(std::vector<ConfigKey>& keys, std::string path)
      : keys_(keys), path_(std::move(path)) {}

  template <class T>
  void field(const char* key, const T& value, Check<T> check = {}) {
    add<T>(key, type_of<T>(), text_of(value), check);
    if constexpr (IsStructVector<T>::value) {
      // Each element's keys, from a default element.
      typename T::value_type element{};
      ConfigReference nested(keys_, join(key) + "[]");
      visit(nested, element);
    }
  }
  template <class T>
  void field(const char* key, const std::optional<T>& value, Check<T> check = {}) {
    add<T>(key, type_of<T>() + ", optional", value ? text_of(*value) : "unset", check);
  }
  template <class S>
  void section(const char* key, S& sub) {
    ConfigReference nested(keys_, join(key));
    visit(nested, sub);
  }

 private:
  template <class T>
  void add(const char* key, std::string type, std::string default_text, const Check<T>& check) {
    ConfigKey row{join(key), std::move(type), std::move(default_text), check.description()};
    if (row.allowed.empty()) row.allowed = check ? "checked" : "any";
    if constexpr (std::is_enum_v<T>) {
      row.allowed = "one of ";
      for (const auto& [enum_value, name] : EnumNames<T>::kAll) {
        (void)enum_value;
        row.allowed += std::string(row.allowed.size() > 7 ? ", " : "") + name;
      }
    }
    keys_.push_back(std::move(row));
  }
  std::string join(const char* key) const { return path_.empty() ? key : path_ + "." + key; }

  template <class T>
  static std::string type_of() {
    if constexpr (std::is_enum_v<T>) return "choice";
    if constexpr (std::is_same_v<T, bool>) return "bool";
    if constexpr (std::is_integral_v<T> && std::is_unsigned_v<T>) return "integer >= 0";
    if constexpr (std::is_integral_v<T>) return "integer";
    if constexpr (std::is_floating_point_v<T>) return "number";
    if constexpr (IsStructVector<T>::value) return "list of mappings";
    if constexpr (IsVector<T>::value) return "list of " + type_of<typename T::value_type>() + "s";
    return "string";
  }
  template <class T>
  static std::string text_of(const T& value) {
    if constexpr (std::is_enum_v<T>) {
      return enum_name(value);
    } else if constexpr (std::is_same_v<T, bool>) {
      return value ? "true" : "false";
    } else if constexpr (std::is_same_v<T, std::string>) {
      return value.empty() ? "\"\"" : value;
    } else if constexpr (IsStructVector<T>::value) {
      return value.empty() ? "[]" : "(" + std::to_string(value.size()) + " entries)";
    } else if constexpr (IsVector<T>::value) {
      std::string out;
      for (const auto& item : value) out += (out.empty() ? "" : ", ") + text_of(item);
      return "[" + out + "]";
    } else {
      std::ostringstream out;
      out << value;
      return out.str();
    }
  }

  std::vector<ConfigKey>& keys_;
  std::string path_;
};

// Every key of `Config` (default-constructed) with its type, default and check, in the order of
// its description; visit(ConfigReference&, Config&) must be defined or instantiated.
template <class Config>
std::vector<ConfigKey> config_keys() {
  std::vector<ConfigKey> keys;
  Config defaults;
  ConfigReference reference(keys, "");
  visit(reference, defaults);
  return keys;
}

// `keys` as a Markdown table (key, type, default, allowed) under a "### title" and an intro:
// one part of docs/configuration.md (`keyfleet config reference` puts them together).
std::string config_reference_table(const std::string& title, const std::string& intro,
                                   const std::vector<ConfigKey>& keys);

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
