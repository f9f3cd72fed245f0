#pragma once
// The station's database (station.sqlite) is one file with one schema version (PRAGMA
// user_version) for every table in it: the keyframe store's, the analysis store's and the
// analysis attempts'. Each of them opens the file through here.
#include "keyfleet/common/sqlite.hpp"

namespace keyfleet::station {

// The newest layout this build writes.
int station_schema_version();

// kReadWrite: runs the migrations the file lacks (a new file gets them all), in one transaction.
// kReadOnly: changes nothing. Both throw SqliteError for a file newer than this build.
void open_station_schema(SqliteDb& db, SqliteDb::Mode mode);

}  // namespace keyfleet::station
