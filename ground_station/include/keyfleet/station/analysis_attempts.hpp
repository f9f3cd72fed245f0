#pragma once
#include <mutex>
#include <string>
#include <vector>

#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/station/analysis_types.hpp"

namespace keyfleet::station {

// How many times each keyframe's analysis was started, in the station's database. A worker
// records the start before it runs the engines, and a finished analysis leaves its result beside
// it, so a keyframe started again and again without a result is one whose analysis ended the
// process (a native crash in an engine, an out-of-memory kill): the station skips it after
// max_attempts instead of dying on it at every start.
class AnalysisAttempts {
 public:
  explicit AnalysisAttempts(const std::string& path);

  // Safe from any thread: counts one more start, committed before it returns.
  void started(const KeyframeKey& key);

  struct Abandoned {
    KeyframeKey key;
    std::int64_t capture_time_ns = 0;
    int attempts = 0;
  };
  // Keyframes started at least max_attempts times that have no result but a deferral.
  std::vector<Abandoned> abandoned(int max_attempts) const;

 private:
  mutable std::mutex mutex_;
  mutable SqliteDb db_;
};

}  // namespace keyfleet::station
