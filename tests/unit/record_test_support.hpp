#pragma once
// Two visitors over a sample's field list (record_fields.hpp) for the round-trip tests: one gives
// every field a value of its own, none the default; the other names the fields two samples differ
// in. A field added to the list is then filled and compared without touching the tests.
#include <cstdint>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "keyfleet/common/record_fields.hpp"

namespace keyfleet::test {

class FillEveryField {
 public:
  template <class T>
  void field(const char*, T& value, Since) {
    ++n_;
    if constexpr (std::is_same_v<T, bool>) {
      value = !value;
    } else if constexpr (std::is_same_v<T, std::string>) {
      value = "text_" + std::to_string(n_);
    } else if constexpr (std::is_same_v<T, std::vector<std::uint8_t>>) {
      value = {0xFF, 0xD8, static_cast<std::uint8_t>(n_), 0xFF, 0xD9};
    } else if constexpr (std::is_same_v<T, std::optional<Pose>>) {
      value = Pose{n_ + 0.5, n_ + 1.5, n_ + 2.5, 0.1, 0.2, 0.3, 0.9};
    } else if constexpr (std::is_same_v<T, std::vector<TextRegion>>) {
      value = {{1, 2, 30, 40}, {static_cast<std::uint16_t>(n_), 6, 7, 8}};
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
      value = {{"select", 12.5, 7}, {"encode", 3.25, static_cast<std::uint64_t>(n_)}};
    } else if constexpr (std::is_floating_point_v<T>) {
      value = static_cast<T>(n_) + 0.25;
    } else {
      value = static_cast<T>(1000 + n_);  // distinct, and not a default
    }
  }

 private:
  int n_ = 0;
};

template <class R>
R every_field_set() {
  R record;
  FillEveryField fill;
  visit_fields(fill, record);
  return record;
}

// Collects each field's value as text, to compare two samples field by field.
class FieldTexts {
 public:
  template <class T>
  void field(const char* name, const T& value, Since) {
    std::string text;
    if constexpr (std::is_same_v<T, std::string>) {
      text = value;
    } else if constexpr (std::is_same_v<T, std::vector<std::uint8_t>>) {
      for (auto b : value) text += std::to_string(b) + " ";
    } else if constexpr (std::is_same_v<T, std::optional<Pose>>) {
      if (value)
        for (double v :
             {value->tx, value->ty, value->tz, value->qx, value->qy, value->qz, value->qw})
          text += std::to_string(v) + " ";
    } else if constexpr (std::is_same_v<T, std::vector<TextRegion>>) {
      for (const auto& r : value)
        text += std::to_string(r.x) + "," + std::to_string(r.y) + "," + std::to_string(r.w) + "," +
                std::to_string(r.h) + " ";
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
      for (const auto& s : value)
        text +=
            s.stage + ":" + std::to_string(s.cpu_ms_total) + ":" + std::to_string(s.calls) + " ";
    } else {
      text = std::to_string(value);
    }
    texts.push_back({name, text});
  }
  std::vector<std::pair<std::string, std::string>> texts;
};

// The fields in which `got` differs from `sent`, but for those a copy leaves out by design.
template <class R>
std::vector<std::string> dropped_fields(const R& sent, const R& got,
                                        const std::set<std::string>& left_out = {}) {
  FieldTexts a, b;
  visit_fields(a, sent);
  visit_fields(b, got);
  std::vector<std::string> out;
  for (std::size_t i = 0; i < a.texts.size(); ++i)
    if (a.texts[i].second != b.texts[i].second && !left_out.count(a.texts[i].first))
      out.push_back(a.texts[i].first + " (sent '" + a.texts[i].second + "', got '" +
                    b.texts[i].second + "')");
  return out;
}

}  // namespace keyfleet::test
