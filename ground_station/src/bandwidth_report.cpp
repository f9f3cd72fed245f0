#include "keyfleet/station/bandwidth_report.hpp"

#include "keyfleet/common/file_output.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

namespace keyfleet::station {
namespace {

double ratio(std::uint64_t numerator, std::uint64_t denominator) {
  return denominator == 0 ? 0.0 : static_cast<double>(numerator) / static_cast<double>(denominator);
}

std::string human_bytes(std::uint64_t bytes) {
  char text[32];
  const double b = static_cast<double>(bytes);
  if (b >= 1e9)
    std::snprintf(text, sizeof text, "%.2f GB", b / 1e9);
  else if (b >= 1e6)
    std::snprintf(text, sizeof text, "%.2f MB", b / 1e6);
  else if (b >= 1e3)
    std::snprintf(text, sizeof text, "%.1f kB", b / 1e3);
  else
    std::snprintf(text, sizeof text, "%llu B", static_cast<unsigned long long>(bytes));
  return text;
}

std::string with_label(std::uint64_t bytes, bool estimated, bool known) {
  if (!known) return "n/a";
  return human_bytes(bytes) + (estimated ? " (est.)" : "");
}

void accumulate(BandwidthRow& sum, const BandwidthRow& r) {
  sum.keyframes_stored += r.keyframes_stored;
  sum.rejected += r.rejected;
  sum.conflicts += r.conflicts;
  sum.bytes_received += r.bytes_received;
  sum.bytes_received_with_baseline += r.bytes_received_with_baseline;
  sum.frames_seen += r.frames_seen;
  sum.vslam_keyframes += r.vslam_keyframes;
  sum.keyframes_sent += r.keyframes_sent;
  sum.keyframes_resent += r.keyframes_resent;
  sum.keyframes_dropped += r.keyframes_dropped;
  sum.keyframes_pending += r.keyframes_pending;
  sum.keyframes_reduced += r.keyframes_reduced;
  sum.keyframes_thinned += r.keyframes_thinned;
  sum.level_changes += r.level_changes;
  sum.link_bytes_per_s += r.link_bytes_per_s;
  sum.bytes_sent_total += r.bytes_sent_total;
  sum.stream_all_bytes += r.stream_all_bytes;
  sum.stream_all_estimated = sum.stream_all_estimated || r.stream_all_estimated;
  sum.vslam_keyframe_bytes += r.vslam_keyframe_bytes;
  sum.vslam_keyframe_estimated = sum.vslam_keyframe_estimated || r.vslam_keyframe_estimated;
  sum.has_agent_stats = sum.has_agent_stats || r.has_agent_stats;
  sum.keyframes_per_minute += r.keyframes_per_minute;
}

}  // namespace

double BandwidthRow::saving_vs_stream_all() const {
  return ratio(stream_all_bytes, bytes_received_with_baseline);
}
double BandwidthRow::saving_vs_vslam() const {
  return ratio(vslam_keyframe_bytes, bytes_received_with_baseline);
}

BandwidthReport build_bandwidth_report(const std::vector<RobotTotals>& totals) {
  BandwidthReport report;
  report.fleet.robot_id = "FLEET";
  report.fleet.agent_finished = true;
  for (const auto& t : totals) {
    BandwidthRow row;
    row.robot_id = t.robot_id;
    row.keyframes_stored = t.keyframes;
    row.rejected = t.rejected;
    row.conflicts = t.conflicts;
    row.bytes_received = t.serialized_bytes;
    const double span_min = static_cast<double>(t.last_received_ns - t.first_received_ns) / 60e9;
    row.keyframes_per_minute = span_min > 0 ? static_cast<double>(t.keyframes) / span_min : 0;
    if (t.latest_stats) {
      const AgentStats& s = *t.latest_stats;
      row.has_agent_stats = true;
      row.bytes_received_with_baseline = t.serialized_bytes;
      row.agent_finished = s.finished;
      row.frames_seen = s.frames_seen;
      row.vslam_keyframes = s.vslam_keyframes;
      row.keyframes_sent = s.keyframes_sent;
      row.keyframes_resent = s.keyframes_resent;
      row.keyframes_dropped = s.keyframes_dropped;
      row.keyframes_pending = s.keyframes_pending;
      row.bytes_sent_total = s.bytes_sent + s.bytes_resent;
      row.stream_all_bytes = s.stream_all_bytes;
      row.stream_all_estimated = s.stream_all_estimated;
      row.vslam_keyframe_bytes = s.vslam_keyframe_bytes;
      row.vslam_keyframe_estimated = s.vslam_keyframe_estimated;
      row.keyframes_reduced = s.keyframes_reduced;
      row.keyframes_thinned = s.keyframes_thinned;
      row.level_changes = s.level_changes;
      row.send_quality = s.send_quality;
      row.send_scale = s.send_scale;
      row.send_density = s.send_density;
      row.link_bytes_per_s = s.link_bytes_per_s;
      row.link_rtt_ms = s.link_rtt_ms;
      row.backlog_s = s.backlog_s;
    }
    report.fleet.agent_finished = report.fleet.agent_finished && row.agent_finished;
    accumulate(report.fleet, row);
    report.robots.push_back(row);
  }
  return report;
}

std::string format_table(const BandwidthReport& report) {
  std::ostringstream out;
  char line[400];
  std::snprintf(line, sizeof line, "%-10s %6s %5s %10s %12s %9s %6s %14s %8s %14s %8s %7s\n",
                "robot", "stored", "rej", "received", "frames seen", "resent", "lost", "stream-all",
                "saving", "every V-SLAM", "saving", "kf/min");
  out << line;
  auto print = [&](const BandwidthRow& r) {
    const bool known = r.has_agent_stats;
    char saving_all[16] = "n/a", saving_vslam[16] = "n/a";
    if (known && r.bytes_received_with_baseline) {
      std::snprintf(saving_all, sizeof saving_all, "%.1fx", r.saving_vs_stream_all());
      std::snprintf(saving_vslam, sizeof saving_vslam, "%.1fx", r.saving_vs_vslam());
    }
    std::snprintf(
        line, sizeof line, "%-10s %6llu %5llu %10s %12s %9llu %6llu %14s %8s %14s %8s %7.1f\n",
        r.robot_id.c_str(), static_cast<unsigned long long>(r.keyframes_stored),
        static_cast<unsigned long long>(r.rejected), human_bytes(r.bytes_received).c_str(),
        known ? std::to_string(r.frames_seen).c_str() : "n/a",
        static_cast<unsigned long long>(r.keyframes_resent),
        static_cast<unsigned long long>(r.keyframes_dropped),
        with_label(r.stream_all_bytes, r.stream_all_estimated, known).c_str(), saving_all,
        with_label(r.vslam_keyframe_bytes, r.vslam_keyframe_estimated, known).c_str(), saving_vslam,
        r.keyframes_per_minute);
    out << line;
  };
  for (const auto& r : report.robots) print(r);
  print(report.fleet);
  // Link adaptation, for the robots that adapted: what they gave up to keep their latency.
  for (const auto& r : report.robots) {
    if (r.level_changes == 0 && r.keyframes_reduced == 0 && r.keyframes_thinned == 0) continue;
    std::snprintf(line, sizeof line,
                  "link adaptation %s: %llu of %llu keyframes sent reduced, %llu held back, %llu "
                  "level changes; now JPEG q%u at %.2g of the frame%s; link %.1f kB/s, round "
                  "trip %.0f ms\n",
                  r.robot_id.c_str(), static_cast<unsigned long long>(r.keyframes_reduced),
                  static_cast<unsigned long long>(r.keyframes_sent),
                  static_cast<unsigned long long>(r.keyframes_thinned),
                  static_cast<unsigned long long>(r.level_changes), r.send_quality, r.send_scale,
                  r.send_density > 1 ? (", one in " + std::to_string(r.send_density)).c_str() : "",
                  r.link_bytes_per_s / 1e3, r.link_rtt_ms);
    out << line;
  }
  const RobotRefusals& refused = report.refused;
  if (refused.any()) {
    std::string ids;
    for (const auto& id : refused.ids) ids += (ids.empty() ? "" : ", ") + id;
    std::snprintf(line, sizeof line,
                  "robots refused: %llu not allowed, %llu over max_robots, %llu malformed ids, "
                  "%llu without an identity, %llu withdrawn; %llu samples refused",
                  static_cast<unsigned long long>(refused.not_allowed),
                  static_cast<unsigned long long>(refused.over_quota),
                  static_cast<unsigned long long>(refused.malformed),
                  static_cast<unsigned long long>(refused.no_identity),
                  static_cast<unsigned long long>(refused.withdrawn),
                  static_cast<unsigned long long>(refused.samples));
    out << line << " (" << ids << ")\n";
  }
  if (!report.dds_security)
    out << "DDS-Security: off (dds.security.enabled: false): keyframes crossed the network "
           "unauthenticated and unencrypted\n";
  out << "received = serialized DDS samples stored by the station (first copies); stream-all = "
         "every camera frame sent as a JPEG keyframe sample; (est.) = extrapolated from sampled "
         "frames; lost = dropped by the agent's outbox bounds.\n";
  return out.str();
}

std::string to_json(const BandwidthReport& report) {
  auto row_json = [](const BandwidthRow& r) {
    return nlohmann::json{{"robot_id", r.robot_id},
                          {"keyframes_stored", r.keyframes_stored},
                          {"rejected", r.rejected},
                          {"conflicts", r.conflicts},
                          {"bytes_received", r.bytes_received},
                          {"bytes_received_with_baseline", r.bytes_received_with_baseline},
                          {"has_agent_stats", r.has_agent_stats},
                          {"agent_finished", r.agent_finished},
                          {"frames_seen", r.frames_seen},
                          {"vslam_keyframes", r.vslam_keyframes},
                          {"keyframes_sent", r.keyframes_sent},
                          {"keyframes_resent", r.keyframes_resent},
                          {"keyframes_dropped", r.keyframes_dropped},
                          {"keyframes_pending", r.keyframes_pending},
                          {"bytes_sent_total", r.bytes_sent_total},
                          {"stream_all_bytes", r.stream_all_bytes},
                          {"stream_all_estimated", r.stream_all_estimated},
                          {"vslam_keyframe_bytes", r.vslam_keyframe_bytes},
                          {"vslam_keyframe_estimated", r.vslam_keyframe_estimated},
                          {"saving_vs_stream_all", r.saving_vs_stream_all()},
                          {"saving_vs_vslam", r.saving_vs_vslam()},
                          {"keyframes_per_minute", r.keyframes_per_minute},
                          {"keyframes_reduced", r.keyframes_reduced},
                          {"keyframes_thinned", r.keyframes_thinned},
                          {"level_changes", r.level_changes},
                          {"send_quality", r.send_quality},
                          {"send_scale", r.send_scale},
                          {"send_density", r.send_density},
                          {"link_bytes_per_s", r.link_bytes_per_s},
                          {"link_rtt_ms", r.link_rtt_ms},
                          {"backlog_s", r.backlog_s}};
  };
  nlohmann::json doc;
  doc["robots"] = nlohmann::json::array();
  for (const auto& r : report.robots) doc["robots"].push_back(row_json(r));
  doc["fleet"] = row_json(report.fleet);
  const RobotRefusals& refused = report.refused;
  doc["dds_security"] = report.dds_security;
  doc["refused_robots"] = {{"no_identity", refused.no_identity},
                           {"withdrawn", refused.withdrawn},
                           {"not_allowed", refused.not_allowed},
                           {"over_quota", refused.over_quota},
                           {"malformed", refused.malformed},
                           {"samples", refused.samples},
                           {"ids", refused.ids}};
  return doc.dump(2);
}

std::string to_csv(const BandwidthReport& report) {
  std::ostringstream out;
  out << "robot_id,keyframes_stored,rejected,bytes_received,frames_seen,vslam_keyframes,"
         "keyframes_sent,keyframes_resent,keyframes_dropped,keyframes_pending,bytes_sent_total,"
         "stream_all_bytes,stream_all_estimated,vslam_keyframe_bytes,vslam_keyframe_estimated,"
         "saving_vs_stream_all,saving_vs_vslam,keyframes_per_minute,keyframes_reduced,"
         "keyframes_thinned,level_changes,send_quality,send_scale,send_density,link_bytes_per_s,"
         "link_rtt_ms\n";
  auto row = [&](const BandwidthRow& r) {
    out << r.robot_id << ',' << r.keyframes_stored << ',' << r.rejected << ',' << r.bytes_received
        << ',' << r.frames_seen << ',' << r.vslam_keyframes << ',' << r.keyframes_sent << ','
        << r.keyframes_resent << ',' << r.keyframes_dropped << ',' << r.keyframes_pending << ','
        << r.bytes_sent_total << ',' << r.stream_all_bytes << ',' << r.stream_all_estimated << ','
        << r.vslam_keyframe_bytes << ',' << r.vslam_keyframe_estimated << ','
        << r.saving_vs_stream_all() << ',' << r.saving_vs_vslam() << ',' << r.keyframes_per_minute
        << ',' << r.keyframes_reduced << ',' << r.keyframes_thinned << ',' << r.level_changes << ','
        << r.send_quality << ',' << r.send_scale << ',' << r.send_density << ','
        << r.link_bytes_per_s << ',' << r.link_rtt_ms << '\n';
  };
  for (const auto& r : report.robots) row(r);
  row(report.fleet);
  return out.str();
}

std::vector<BandwidthSeries> build_bandwidth_timeline(
    const std::vector<StoredKeyframeInfo>& keyframes, const std::vector<StatsSample>& stats) {
  std::map<std::string, BandwidthSeries> by_robot;
  auto series = [&](const std::string& robot) -> BandwidthSeries& {
    BandwidthSeries& s = by_robot[robot];
    s.robot_id = robot;
    return s;
  };
  std::vector<const StoredKeyframeInfo*> by_time;
  for (const auto& k : keyframes) by_time.push_back(&k);
  std::stable_sort(by_time.begin(), by_time.end(),
                   [](auto* a, auto* b) { return a->received_ns < b->received_ns; });
  for (const StoredKeyframeInfo* k : by_time) {
    auto& received = series(k->robot_id).received;
    const std::uint64_t before = received.empty() ? 0 : received.back().bytes;
    received.push_back({k->received_ns, before + k->serialized_bytes});
  }
  for (const StatsSample& s : stats) {
    BandwidthSeries& out = series(s.robot_id);
    out.stream_all.push_back({s.report_time_ns, s.stream_all_bytes});
    out.vslam_keyframes.push_back({s.report_time_ns, s.vslam_keyframe_bytes});
  }
  std::vector<BandwidthSeries> out;
  for (auto& [robot, s] : by_robot) out.push_back(std::move(s));
  return out;
}

std::string write_bandwidth_report(const BandwidthReport& report, const std::string& run_dir) {
  const std::filesystem::path dir(run_dir);
  write_file(dir / "report.json", to_json(report) + "\n");
  write_file(dir / "report.csv", to_csv(report));
  const std::string table = format_table(report);
  write_file(dir / "report.txt", table);
  return table;
}

}  // namespace keyfleet::station
