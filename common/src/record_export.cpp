#include "keyfleet/common/record_export.hpp"

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <type_traits>
#include <vector>

#include "keyfleet/common/record_fields.hpp"

namespace keyfleet {
namespace {

using Json = nlohmann::ordered_json;
constexpr const char* kPose[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};

double* pose_value(Pose& p, int i) {
  double* values[7] = {&p.tx, &p.ty, &p.tz, &p.qx, &p.qy, &p.qz, &p.qw};
  return values[i];
}

class JsonWriter {
 public:
  template <class T>
  void field(const char* name, const T& value, Since) {
    if constexpr (std::is_same_v<T, std::vector<std::uint8_t>>) {
      doc[std::string(name) + "_bytes"] = value.size();
    } else if constexpr (std::is_same_v<T, std::optional<Pose>>) {
      Json& pose = doc[name] = nullptr;
      if (!value) return;
      Pose p = *value;
      for (int i = 0; i < 7; ++i) pose[kPose[i]] = *pose_value(p, i);
    } else if constexpr (std::is_same_v<T, std::vector<TextRegion>>) {
      Json& regions = doc[name] = Json::array();
      for (const TextRegion& r : value) regions.push_back({r.x, r.y, r.w, r.h});
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
      Json& stages = doc[name] = Json::array();
      for (const StageTime& s : value)
        stages.push_back(
            {{"stage", s.stage}, {"cpu_ms_total", s.cpu_ms_total}, {"calls", s.calls}});
    } else {
      doc[name] = value;
    }
  }
  Json doc = Json::object();
};

class JsonReader {
 public:
  explicit JsonReader(const Json& doc) : doc_(doc) {}
  template <class T>
  void field(const char* name, T& value, Since) {
    if constexpr (std::is_same_v<T, std::vector<std::uint8_t>>) {
      value.clear();  // only the size was written
    } else {
      const Json& j = doc_.at(name);
      if constexpr (std::is_same_v<T, std::optional<Pose>>) {
        value.reset();
        if (j.is_null()) return;
        Pose p;
        for (int i = 0; i < 7; ++i) *pose_value(p, i) = j.at(kPose[i]).get<double>();
        value = p;
      } else if constexpr (std::is_same_v<T, std::vector<TextRegion>>) {
        value.clear();
        for (const Json& r : j)
          value.push_back({r.at(0).get<std::uint16_t>(), r.at(1).get<std::uint16_t>(),
                           r.at(2).get<std::uint16_t>(), r.at(3).get<std::uint16_t>()});
      } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
        value.clear();
        for (const Json& s : j)
          value.push_back({s.at("stage").get<std::string>(), s.at("cpu_ms_total").get<double>(),
                           s.at("calls").get<std::uint64_t>()});
      } else {
        value = j.get<T>();
      }
    }
  }

 private:
  const Json& doc_;
};

template <class R>
Json json_of(const R& record) {
  JsonWriter writer;
  visit_fields(writer, record);
  return writer.doc;
}

template <class R>
void read_json(const Json& doc, R& record) {
  try {
    JsonReader reader(doc);
    visit_fields(reader, record);
  } catch (const Json::exception& e) {
    throw std::invalid_argument(std::string("not a sample: ") + e.what());
  }
}

// The CSV view flattens the JSON object: the pose into seven cells, every other value as its
// JSON text (strings quoted CSV-style).
Json flat(const Json& doc) {
  Json out = Json::object();
  for (const auto& [key, value] : doc.items()) {
    if (key == "camera_pose") {
      for (const char* p : kPose) out[key + "_" + p] = value.is_null() ? Json() : value.at(p);
    } else {
      out[key] = value;
    }
  }
  return out;
}

std::string cell(const Json& value) {
  if (value.is_null()) return "";
  std::string text = value.is_string() ? value.get<std::string>() : value.dump();
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::vector<std::string> split_csv(const std::string& row) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (std::size_t i = 0; i < row.size(); ++i) {
    const char c = row[i];
    if (quoted && c == '"' && i + 1 < row.size() && row[i + 1] == '"') {
      cells.back() += '"', ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      cells.emplace_back();
    } else {
      cells.back() += c;
    }
  }
  return cells;
}

template <class R>
std::string row_of(const R& record) {
  const Json cells = flat(json_of(record));
  std::string out;
  for (const auto& [key, value] : cells.items()) out += (out.empty() ? "" : ",") + cell(value);
  return out;
}

template <class R>
void read_row(const std::string& row, R& record) {
  const Json names = flat(json_of(R{}));  // the header's columns, with their value kinds
  const std::vector<std::string> cells = split_csv(row);
  if (cells.size() != names.size())
    throw std::invalid_argument("CSV row of " + std::to_string(cells.size()) + " cells, " +
                                std::to_string(names.size()) + " expected");
  Json doc = Json::object();
  std::size_t i = 0;
  for (const auto& [key, kind] : names.items()) {
    const std::string& text = cells[i++];
    Json value = kind.is_string() ? Json(text)
                 : text.empty()   ? Json()
                                  : Json::parse(text, nullptr, false);
    if (value.is_discarded()) throw std::invalid_argument("CSV cell " + key + ": " + text);
    if (key.rfind("camera_pose_", 0) == 0) {
      if (!value.is_null()) doc["camera_pose"][key.substr(12)] = value;
    } else {
      doc[key] = value;
    }
  }
  if (!doc.contains("camera_pose") && names.contains("camera_pose_tx"))
    doc["camera_pose"] = nullptr;
  read_json(doc, record);
}

}  // namespace

std::string to_json(const Keyframe& keyframe) { return json_of(keyframe).dump(); }
std::string to_json(const AgentStats& stats) { return json_of(stats).dump(); }
void from_json(const std::string& text, Keyframe& keyframe) {
  read_json(Json::parse(text, nullptr, false), keyframe);
}
void from_json(const std::string& text, AgentStats& stats) {
  read_json(Json::parse(text, nullptr, false), stats);
}

template <class R>
std::string csv_header() {
  const Json names = flat(json_of(R{}));
  std::string out;
  for (const auto& [key, value] : names.items()) out += (out.empty() ? "" : ",") + key;
  return out;
}
template std::string csv_header<Keyframe>();
template std::string csv_header<AgentStats>();

std::string csv_row(const Keyframe& keyframe) { return row_of(keyframe); }
std::string csv_row(const AgentStats& stats) { return row_of(stats); }
void from_csv_row(const std::string& row, Keyframe& keyframe) { read_row(row, keyframe); }
void from_csv_row(const std::string& row, AgentStats& stats) { read_row(row, stats); }

}  // namespace keyfleet
