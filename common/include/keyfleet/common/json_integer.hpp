#pragma once
// Integer fields of JSON files. nlohmann::json converts whatever number a field holds to the
// integer asked for, a float out of the type's range included (undefined behaviour: 8.3e19 into
// an int64, found by fuzz_scenario_truth). These take a JSON integer within T's range and throw
// std::runtime_error saying what was there otherwise. Header-only; the includer links
// nlohmann_json.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace keyfleet {

template <class T>
T json_integer(const nlohmann::json& j) {
  using Limits = std::numeric_limits<T>;
  static_assert(Limits::is_integer, "json_integer reads integer types");
  if (j.is_number_unsigned()) {
    const std::uint64_t v = j.get<std::uint64_t>();
    if (v <= static_cast<std::uint64_t>(Limits::max())) return static_cast<T>(v);
  } else if (j.is_number_integer()) {
    const std::int64_t v = j.get<std::int64_t>();
    if (v >= 0 ? static_cast<std::uint64_t>(v) <= static_cast<std::uint64_t>(Limits::max())
               : Limits::is_signed && v >= static_cast<std::int64_t>(Limits::min()))
      return static_cast<T>(v);
  } else {
    throw std::runtime_error(std::string("expected an integer, found ") + j.type_name() +
                             (j.is_number() ? " " + j.dump() : ""));
  }
  throw std::runtime_error("integer " + j.dump() + " out of range");
}

// Field `key` of object j as above, or `otherwise` where j has no such field.
template <class T>
T json_integer_or(const nlohmann::json& j, const char* key, T otherwise) {
  const auto it = j.find(key);
  return it == j.end() ? otherwise : json_integer<T>(*it);
}

}  // namespace keyfleet
