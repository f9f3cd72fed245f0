#include "keyfleet/common/record_sql.hpp"

#include <cstring>
#include <type_traits>

#include "keyfleet/common/record_fields.hpp"
#include "keyfleet/common/text_region_blob.hpp"

namespace keyfleet {
namespace {

constexpr const char* kPoseColumns[7] = {"pose_tx", "pose_ty", "pose_tz", "pose_qx",
                                         "pose_qy", "pose_qz", "pose_qw"};

int version_in(Since since, RecordStore store) {
  return store == RecordStore::kOutbox ? since.outbox : since.station;
}

std::vector<std::uint8_t> pose_blob(const Pose& p) {
  const double values[7] = {p.tx, p.ty, p.tz, p.qx, p.qy, p.qz, p.qw};
  std::vector<std::uint8_t> blob(sizeof(values));
  std::memcpy(blob.data(), values, sizeof(values));
  return blob;
}

std::optional<Pose> pose_from_blob(const std::vector<std::uint8_t>& blob) {
  double v[7];
  if (blob.size() != sizeof(v)) return std::nullopt;
  std::memcpy(v, blob.data(), sizeof(v));
  return Pose{v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
}

class ColumnLister {
 public:
  explicit ColumnLister(RecordStore store) : store_(store) {}
  template <class T>
  void field(const char* name, const T&, Since since) {
    const int version = version_in(since, store_);
    if (version == 0) return;
    if constexpr (std::is_same_v<T, std::optional<Pose>>) {
      if (store_ == RecordStore::kOutbox)
        columns.push_back({"pose", "BLOB", version});
      else
        for (const char* column : kPoseColumns) columns.push_back({column, "REAL", version});
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
      // kept in a table of its own
    } else {
      columns.push_back({name, declaration<T>(), version});
    }
  }
  std::vector<SqlColumn> columns;

 private:
  template <class T>
  static const char* declaration() {
    if constexpr (std::is_same_v<T, std::string>) return "TEXT NOT NULL";
    if constexpr (std::is_same_v<T, std::vector<std::uint8_t>>) return "BLOB NOT NULL";
    if constexpr (std::is_same_v<T, std::vector<TextRegion>>) return "BLOB";
    if constexpr (std::is_floating_point_v<T>) return "REAL NOT NULL";
    if constexpr (std::is_integral_v<T>) return "INTEGER NOT NULL";
  }
  RecordStore store_;
};

class Binder {
 public:
  Binder(SqliteStatement& statement, RecordStore store) : s_(statement), store_(store) {}
  template <class T>
  void field(const char* name, const T& value, Since since) {
    if (version_in(since, store_) == 0) return;
    if constexpr (std::is_same_v<T, std::optional<Pose>>) {
      if (store_ == RecordStore::kOutbox) {
        if (const int i = index("pose")) value ? s_.bind(i, pose_blob(*value)) : s_.bind_null(i);
        return;
      }
      const Pose p = value.value_or(Pose{});
      const double values[7] = {p.tx, p.ty, p.tz, p.qx, p.qy, p.qz, p.qw};
      for (int c = 0; c < 7; ++c)
        if (const int i = index(kPoseColumns[c])) value ? s_.bind(i, values[c]) : s_.bind_null(i);
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
    } else if (const int i = index(name)) {
      if constexpr (std::is_same_v<T, std::vector<TextRegion>>) {
        value.empty() ? s_.bind_null(i) : s_.bind(i, text_regions_blob(value));
      } else if constexpr (std::is_same_v<T, std::string> ||
                           std::is_same_v<T, std::vector<std::uint8_t>>) {
        s_.bind(i, value);
      } else if constexpr (std::is_floating_point_v<T>) {
        s_.bind(i, static_cast<double>(value));
      } else {
        s_.bind(i, static_cast<std::int64_t>(value));  // unsigned counters as their bits
      }
    }
  }

 private:
  int index(const char* column) const { return s_.parameter_index(std::string(":") + column); }
  SqliteStatement& s_;
  RecordStore store_;
};

class Reader {
 public:
  Reader(const SqliteStatement& row, RecordStore store) : row_(row), store_(store) {}
  template <class T>
  void field(const char* name, T& value, Since since) {
    if (version_in(since, store_) == 0) return;
    if constexpr (std::is_same_v<T, std::optional<Pose>>) {
      if (store_ == RecordStore::kOutbox) {
        const int i = row_.column_index("pose");
        if (i >= 0 && !row_.is_null(i)) value = pose_from_blob(row_.blob(i));
        return;
      }
      int c[7];
      for (int k = 0; k < 7; ++k) c[k] = row_.column_index(kPoseColumns[k]);
      if (c[0] < 0 || row_.is_null(c[0])) return;
      auto at = [&](int k) { return c[k] < 0 ? 0.0 : row_.real(c[k]); };
      value = Pose{at(0), at(1), at(2), at(3), at(4), at(5), at(6)};
    } else if constexpr (std::is_same_v<T, std::vector<StageTime>>) {
    } else {
      const int i = row_.column_index(name);
      if (i < 0) return;
      if constexpr (std::is_same_v<T, std::vector<TextRegion>>) {
        if (!row_.is_null(i)) value = text_regions_from_blob(row_.blob(i));
      } else if constexpr (std::is_same_v<T, std::string>) {
        value = row_.text(i);
      } else if constexpr (std::is_same_v<T, std::vector<std::uint8_t>>) {
        value = row_.blob(i);
      } else if constexpr (std::is_same_v<T, bool>) {
        value = row_.int64(i) != 0;
      } else if constexpr (std::is_floating_point_v<T>) {
        value = static_cast<T>(row_.real(i));
      } else {
        value = static_cast<T>(row_.int64(i));
      }
    }
  }

 private:
  const SqliteStatement& row_;
  RecordStore store_;
};

// A column added to a table that has rows needs a default when it may not be NULL.
std::string added_declaration(const SqlColumn& column) {
  const std::string& d = column.declaration;
  if (d.find("NOT NULL") == std::string::npos) return d;
  if (d.rfind("TEXT", 0) == 0) return d + " DEFAULT ''";
  if (d.rfind("BLOB", 0) == 0) return d + " DEFAULT x''";
  return d + " DEFAULT 0";
}

}  // namespace

template <class R>
std::vector<SqlColumn> sql_columns(RecordStore store) {
  ColumnLister lister(store);
  const R record{};
  visit_fields(lister, record);
  return lister.columns;
}

template <class R>
void bind_record(SqliteStatement& statement, const R& record, RecordStore store) {
  Binder binder(statement, store);
  visit_fields(binder, record);
}

template <class R>
void read_record(const SqliteStatement& row, R& record, RecordStore store) {
  Reader reader(row, store);
  visit_fields(reader, record);
}

template <class R>
std::vector<Migration> column_migrations(const std::string& table, RecordStore store) {
  std::vector<Migration> out;
  for (const SqlColumn& column : sql_columns<R>(store)) {
    if (column.since <= 1) continue;
    out.push_back({column.since, "", [table, column](SqliteDb& db) {
                     db.add_column_if_missing(table, column.name, added_declaration(column));
                   }});
  }
  return out;
}

std::string column_list(const std::vector<SqlColumn>& columns, const std::string& prefix) {
  std::string out;
  for (const SqlColumn& c : columns) out += (out.empty() ? "" : ", ") + prefix + c.name;
  return out;
}

template std::vector<SqlColumn> sql_columns<Keyframe>(RecordStore);
template std::vector<SqlColumn> sql_columns<AgentStats>(RecordStore);
template void bind_record(SqliteStatement&, const Keyframe&, RecordStore);
template void bind_record(SqliteStatement&, const AgentStats&, RecordStore);
template void read_record(const SqliteStatement&, Keyframe&, RecordStore);
template void read_record(const SqliteStatement&, AgentStats&, RecordStore);
template std::vector<Migration> column_migrations<Keyframe>(const std::string&, RecordStore);
template std::vector<Migration> column_migrations<AgentStats>(const std::string&, RecordStore);

}  // namespace keyfleet
