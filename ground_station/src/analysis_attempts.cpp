#include "keyfleet/station/analysis_attempts.hpp"

#include "keyfleet/station/station_schema.hpp"

namespace keyfleet::station {

AnalysisAttempts::AnalysisAttempts(const std::string& path) : db_(path) {
  open_station_schema(db_, SqliteDb::Mode::kReadWrite);
}

void AnalysisAttempts::started(const KeyframeKey& key) {
  std::lock_guard lock(mutex_);
  db_.prepare(
         "INSERT INTO analysis_attempts(robot_id, sequence_number, attempts) VALUES(?,?,1) "
         "ON CONFLICT(robot_id, sequence_number) DO UPDATE SET attempts = attempts + 1")
      .bind(1, key.robot_id)
      .bind(2, static_cast<std::int64_t>(key.sequence))
      .step();
}

std::vector<AnalysisAttempts::Abandoned> AnalysisAttempts::abandoned(int max_attempts) const {
  std::lock_guard lock(mutex_);
  auto query = db_.prepare(
      "SELECT t.robot_id, t.sequence_number, k.capture_time_ns, t.attempts FROM analysis_attempts "
      "t JOIN keyframes k ON k.robot_id = t.robot_id AND k.sequence_number = t.sequence_number "
      "LEFT JOIN keyframe_analysis a ON a.robot_id = t.robot_id AND a.sequence_number = "
      "t.sequence_number WHERE t.attempts >= ? AND (a.status IS NULL OR a.status = 'deferred') "
      "ORDER BY k.received_ns");
  query.bind(1, std::int64_t{max_attempts});
  std::vector<Abandoned> out;
  while (query.step()) {
    out.push_back({{query.text(0), static_cast<std::uint64_t>(query.int64(1))},
                   query.int64(2),
                   static_cast<int>(query.int64(3))});
  }
  return out;
}

}  // namespace keyfleet::station
