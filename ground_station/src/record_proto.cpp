#include "keyfleet/station/record_proto.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <type_traits>

#include "keyfleet/common/record_fields.hpp"

namespace keyfleet::station {
namespace {

namespace pb = google::protobuf;

// Scalars and text go field by field; the image, the pose and the regions are not logged.
template <class T>
constexpr bool kLogged = std::is_arithmetic_v<T> || std::is_same_v<T, std::string>;

template <class T>
void set(pb::Message& m, const pb::FieldDescriptor* f, const T& v) {
  const pb::Reflection* r = m.GetReflection();
  if constexpr (std::is_same_v<T, std::string>) {
    r->SetString(&m, f, v);
  } else {
    switch (f->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_BOOL: r->SetBool(&m, f, v != T{}); break;
      case pb::FieldDescriptor::CPPTYPE_INT32:
        r->SetInt32(&m, f, static_cast<std::int32_t>(v));
        break;
      case pb::FieldDescriptor::CPPTYPE_INT64:
        r->SetInt64(&m, f, static_cast<std::int64_t>(v));
        break;
      case pb::FieldDescriptor::CPPTYPE_UINT32:
        r->SetUInt32(&m, f, static_cast<std::uint32_t>(v));
        break;
      case pb::FieldDescriptor::CPPTYPE_UINT64:
        r->SetUInt64(&m, f, static_cast<std::uint64_t>(v));
        break;
      case pb::FieldDescriptor::CPPTYPE_DOUBLE: r->SetDouble(&m, f, static_cast<double>(v)); break;
      case pb::FieldDescriptor::CPPTYPE_FLOAT: r->SetFloat(&m, f, static_cast<float>(v)); break;
      default: break;
    }
  }
}

template <class T>
void get(const pb::Message& m, const pb::FieldDescriptor* f, T& v) {
  const pb::Reflection* r = m.GetReflection();
  if constexpr (std::is_same_v<T, std::string>) {
    v = r->GetString(m, f);
  } else {
    switch (f->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_BOOL: v = static_cast<T>(r->GetBool(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_INT32: v = static_cast<T>(r->GetInt32(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_INT64: v = static_cast<T>(r->GetInt64(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_UINT32: v = static_cast<T>(r->GetUInt32(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_UINT64: v = static_cast<T>(r->GetUInt64(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_DOUBLE: v = static_cast<T>(r->GetDouble(m, f)); break;
      case pb::FieldDescriptor::CPPTYPE_FLOAT: v = static_cast<T>(r->GetFloat(m, f)); break;
      default: break;
    }
  }
}

const pb::FieldDescriptor* field_of(const pb::Message& m, const char* name) {
  return m.GetDescriptor()->FindFieldByName(name);
}

class Writer {
 public:
  explicit Writer(pb::Message& m) : m_(m) {}
  template <class T>
  void field(const char* name, const T& value, Since) {
    if constexpr (kLogged<T>) {
      if (const auto* f = field_of(m_, name)) set(m_, f, value);
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
      const auto* f = field_of(m_, name);
      if (!f) return;
      for (const StageTime& s : value) {
        pb::Message* stage = m_.GetReflection()->AddMessage(&m_, f);
        Writer w(*stage);
        w.field("stage", s.stage, {});
        w.field("cpu_ms_total", s.cpu_ms_total, {});
        w.field("calls", s.calls, {});
      }
    }
  }

 private:
  pb::Message& m_;
};

class Reader {
 public:
  explicit Reader(const pb::Message& m) : m_(m) {}
  template <class T>
  void field(const char* name, T& value, Since) {
    if constexpr (kLogged<T>) {
      if (const auto* f = field_of(m_, name)) get(m_, f, value);
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
      const auto* f = field_of(m_, name);
      if (!f) return;
      const pb::Reflection* r = m_.GetReflection();
      for (int i = 0; i < r->FieldSize(m_, f); ++i) {
        Reader stage(r->GetRepeatedMessage(m_, f, i));
        StageTime s;
        stage.field("stage", s.stage, {});
        stage.field("cpu_ms_total", s.cpu_ms_total, {});
        stage.field("calls", s.calls, {});
        value.push_back(s);
      }
    }
  }

 private:
  const pb::Message& m_;
};

class MissingFinder {
 public:
  explicit MissingFinder(const pb::Message& m) : m_(m) {}
  template <class T>
  void field(const char* name, const T&, Since) {
    if (kLogged<T> && !field_of(m_, name)) missing.push_back(name);
  }
  std::vector<std::string> missing;

 private:
  const pb::Message& m_;
};

template <class R>
std::vector<std::string> missing_in(const pb::Message& message) {
  MissingFinder finder(message);
  const R record{};
  visit_fields(finder, record);
  return finder.missing;
}

}  // namespace

void to_proto(const Keyframe& keyframe, pb::Message& message) {
  Writer w(message);
  visit_fields(w, keyframe);
}
void to_proto(const AgentStats& stats, pb::Message& message) {
  Writer w(message);
  visit_fields(w, stats);
}
void from_proto(const pb::Message& message, Keyframe& keyframe) {
  Reader r(message);
  visit_fields(r, keyframe);
}
void from_proto(const pb::Message& message, AgentStats& stats) {
  Reader r(message);
  visit_fields(r, stats);
}

std::vector<std::string> fields_missing_from(const pb::Message& message, const Keyframe&) {
  return missing_in<Keyframe>(message);
}
std::vector<std::string> fields_missing_from(const pb::Message& message, const AgentStats&) {
  return missing_in<AgentStats>(message);
}

}  // namespace keyfleet::station
