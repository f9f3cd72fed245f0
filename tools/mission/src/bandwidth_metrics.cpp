#include "keyfleet/mission/bandwidth_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/record_sql.hpp"
#include "keyfleet/common/sqlite.hpp"

namespace keyfleet::mission {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const auto low = static_cast<std::size_t>(std::floor(rank));
  const auto high = std::min(low + 1, values.size() - 1);
  return values[low] + (rank - static_cast<double>(low)) * (values[high] - values[low]);
}

double median(std::vector<double> values) { return percentile(std::move(values), 50); }

std::vector<std::uint64_t> bytes_per_bin(const std::vector<DeliveredKeyframe>& keyframes,
                                         std::int64_t origin_ns, std::int64_t bin_ns) {
  std::vector<std::uint64_t> bins;
  if (bin_ns <= 0) return bins;
  for (const auto& k : keyframes) {
    const auto bin =
        static_cast<std::size_t>(std::max<std::int64_t>(0, k.received_ns - origin_ns) / bin_ns);
    if (bin >= bins.size()) bins.resize(bin + 1, 0);
    bins[bin] += k.serialized_bytes;
  }
  return bins;
}

double throughput_bytes_per_s(const std::vector<DeliveredKeyframe>& keyframes) {
  if (keyframes.size() < 2) return 0;
  auto first = keyframes.begin();
  std::int64_t last_ns = first->received_ns;
  std::uint64_t bytes = 0;
  for (auto it = keyframes.begin(); it != keyframes.end(); ++it) {
    if (it->received_ns < first->received_ns) first = it;
    last_ns = std::max(last_ns, it->received_ns);
  }
  for (auto it = keyframes.begin(); it != keyframes.end(); ++it)
    if (it != first) bytes += it->serialized_bytes;
  const double span_s = static_cast<double>(last_ns - first->received_ns) / 1e9;
  return span_s > 0 ? static_cast<double>(bytes) / span_s : 0;
}

double saving_ratio(std::uint64_t baseline_bytes, std::uint64_t sent_bytes) {
  return sent_bytes == 0 ? 0
                         : static_cast<double>(baseline_bytes) / static_cast<double>(sent_bytes);
}

RobotMetrics robot_metrics(const std::string& robot_id,
                           const std::vector<DeliveredKeyframe>& keyframes,
                           const std::optional<AgentTotals>& totals,
                           const std::optional<WireBytes>& wire, std::int64_t capture_origin_ns) {
  RobotMetrics m;
  m.robot_id = robot_id;
  std::vector<DeliveredKeyframe> mine;
  std::vector<double> latencies_ms;
  for (const auto& k : keyframes) {
    if (k.robot_id != robot_id) continue;
    mine.push_back(k);
    m.payload_bytes += k.serialized_bytes;
    latencies_ms.push_back(
        static_cast<double>(k.received_ns - (capture_origin_ns + k.capture_time_ns)) / 1e6);
  }
  m.delivered = mine.size();
  m.latency_median_ms = median(latencies_ms);
  m.latency_p95_ms = percentile(latencies_ms, 95);
  m.throughput_bytes_per_s = throughput_bytes_per_s(mine);
  m.wire = wire;
  if (totals) {
    m.agent_stats_seen = true;
    m.dropped = totals->keyframes_dropped;
    m.reduced = totals->keyframes_reduced;
    m.thinned = totals->keyframes_thinned;
    m.level_changes = totals->level_changes;
    m.resent = totals->keyframes_resent;
    m.sent_bytes = totals->bytes_sent + totals->bytes_resent;
    m.stream_all_bytes = totals->stream_all_bytes;
    m.stream_all_estimated = totals->stream_all_estimated;
    m.vslam_keyframe_bytes = totals->vslam_keyframe_bytes;
    m.vslam_keyframe_estimated = totals->vslam_keyframe_estimated;
    m.saving_vs_stream_all = saving_ratio(m.stream_all_bytes, m.payload_bytes);
    m.saving_vs_vslam = saving_ratio(m.vslam_keyframe_bytes, m.payload_bytes);
  }
  return m;
}

StationRecords read_station_records(const std::string& database_path) {
  if (!std::filesystem::exists(database_path))
    throw StartupError(database_path + ": station database not found");
  StationRecords records;
  try {
    SqliteDb db(database_path, SqliteDb::Mode::kReadOnly);
    auto keyframes = db.prepare(
        "SELECT robot_id, capture_time_ns, received_ns, serialized_bytes, sequence_number FROM "
        "keyframes ORDER BY robot_id, received_ns");
    while (keyframes.step())
      records.keyframes.push_back({keyframes.text(0), keyframes.int64(1), keyframes.int64(2),
                                   static_cast<std::uint64_t>(keyframes.int64(3)),
                                   keyframes.int64(4)});
    auto stats = db.prepare("SELECT * FROM agent_stats");
    while (stats.step()) {
      AgentStats s;
      read_record(stats, s, RecordStore::kStation);
      records.agents[s.robot_id] = s;
    }
  } catch (const SqliteError& e) {
    throw StartupError(database_path + ": not a readable station database (" + e.what() + ")");
  }
  return records;
}

std::optional<std::int64_t> stream_start_from_log(const std::string& agent_log_path) {
  return log_time_of(agent_log_path, {"station matched", "streaming anyway"});
}

std::optional<std::int64_t> log_time_of(const std::string& log_path,
                                        const std::vector<std::string>& needles) {
  std::ifstream log(log_path);
  for (std::string line; std::getline(log, line);) {
    bool found = needles.empty();
    for (const auto& needle : needles) found = found || line.find(needle) != std::string::npos;
    if (!found) continue;
    std::tm tm{};
    int millis = 0;
    // "2024-05-01 17:33:31.123 [agent] info station matched"
    if (std::sscanf(line.c_str(), "%d-%d-%d %d:%d:%d.%d", &tm.tm_year, &tm.tm_mon, &tm.tm_mday,
                    &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &millis) != 7)
      continue;
    tm.tm_year -= 1900;
    tm.tm_mon -= 1;
    tm.tm_isdst = -1;
    const std::time_t seconds = std::mktime(&tm);
    if (seconds < 0) continue;
    return static_cast<std::int64_t>(seconds) * 1'000'000'000 +
           static_cast<std::int64_t>(millis) * 1'000'000;
  }
  return std::nullopt;
}

std::uint64_t count_refused_writes(const std::string& agent_log_path) {
  std::ifstream log(agent_log_path);
  std::uint64_t count = 0;
  for (std::string line; std::getline(log, line);)
    if (line.find("not sent now") != std::string::npos) ++count;
  return count;
}

}  // namespace keyfleet::mission
