#pragma once
// A sample's columns in a store's table, from its field list (record_fields.hpp): their
// declarations, the migrations that added the later ones, statements bound by name (":column")
// and rows read by column name. Special cases: camera_pose is seven REAL columns pose_tx..pose_qw
// at the station and one BLOB "pose" in the outbox (NULL without a pose); text_regions is a BLOB
// (text_region_blob.hpp), NULL when empty; AgentStats::stages has its own table, no column.
#include <string>
#include <vector>

#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/sqlite_schema.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet {

enum class RecordStore { kOutbox, kStation };

struct SqlColumn {
  std::string name;
  std::string declaration;  // as in CREATE TABLE: "INTEGER NOT NULL", "BLOB", ...
  int since = 1;            // the store's schema version that added the column
};

// The record's columns in that store, in field order.
template <class R>
std::vector<SqlColumn> sql_columns(RecordStore store);

// Binds every parameter of `statement` named after one of the record's columns (":name").
template <class R>
void bind_record(SqliteStatement& statement, const R& record, RecordStore store);

// Fills the record's fields from the row's columns of the same names; fields whose columns the
// row lacks (a file older than the field) keep their defaults.
template <class R>
void read_record(const SqliteStatement& row, R& record, RecordStore store);

// One migration for each column added after the table's first layout (since > 1).
template <class R>
std::vector<Migration> column_migrations(const std::string& table, RecordStore store);

// "a, b, c"; with a prefix ":" the matching named parameters ":a, :b, :c".
std::string column_list(const std::vector<SqlColumn>& columns, const std::string& prefix = "");

extern template std::vector<SqlColumn> sql_columns<Keyframe>(RecordStore);
extern template std::vector<SqlColumn> sql_columns<AgentStats>(RecordStore);
extern template void bind_record(SqliteStatement&, const Keyframe&, RecordStore);
extern template void bind_record(SqliteStatement&, const AgentStats&, RecordStore);
extern template void read_record(const SqliteStatement&, Keyframe&, RecordStore);
extern template void read_record(const SqliteStatement&, AgentStats&, RecordStore);
extern template std::vector<Migration> column_migrations<Keyframe>(const std::string&, RecordStore);
extern template std::vector<Migration> column_migrations<AgentStats>(const std::string&,
                                                                     RecordStore);

}  // namespace keyfleet
