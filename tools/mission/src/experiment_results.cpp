// The bandwidth experiment's files: results.json (everything, for the plots), results.csv
// (one row per mission and robot) and the summary table.
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "keyfleet/common/error.hpp"
#include "keyfleet/mission/bandwidth_experiment.hpp"
#include "keyfleet/mission/experiment_config.hpp"

namespace keyfleet::mission {
namespace {

using nlohmann::json;

json machine() {
  json m;
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  m["hostname"] = host;
  m["cpus"] = std::thread::hardware_concurrency();
  utsname uts{};
  if (::uname(&uts) == 0) m["kernel"] = std::string(uts.sysname) + " " + uts.release;
  const std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S %Z", std::localtime(&now));
  m["date"] = date;
  return m;
}

json robot_json(const RobotOutcome& r) {
  const RobotMetrics& m = r.metrics;
  json j;
  j["robot_id"] = m.robot_id;
  j["delivered"] = m.delivered;
  j["frames_seen"] = r.frames_seen;
  j["latency_median_ms"] = r.latency_measured ? json(m.latency_median_ms) : json(nullptr);
  j["latency_p95_ms"] = r.latency_measured ? json(m.latency_p95_ms) : json(nullptr);
  j["dropped"] = m.dropped;
  j["keyframes_reduced"] = m.reduced;
  j["keyframes_thinned"] = m.thinned;
  j["level_changes"] = m.level_changes;
  j["resent"] = m.resent;
  j["refused_writes"] = m.refused_writes;
  j["payload_bytes"] = m.payload_bytes;
  j["sent_bytes"] = m.sent_bytes;
  j["wire_tx_bytes"] = m.wire ? json(m.wire->tx_bytes) : json(nullptr);  // null: not measured
  j["wire_rx_bytes"] = m.wire ? json(m.wire->rx_bytes) : json(nullptr);
  j["throughput_bytes_per_s"] = m.throughput_bytes_per_s;
  j["stream_all_bytes"] = m.stream_all_bytes;
  j["stream_all_estimated"] = m.stream_all_estimated;
  j["vslam_keyframe_bytes"] = m.vslam_keyframe_bytes;
  j["vslam_keyframe_estimated"] = m.vslam_keyframe_estimated;
  j["saving_vs_stream_all"] = m.saving_vs_stream_all;
  j["saving_vs_vslam"] = m.saving_vs_vslam;
  j["agent_stats_seen"] = m.agent_stats_seen;
  j["bytes_per_bin"] = r.bytes_per_bin;
  j["pending"] = r.pending;
  j["matched_s"] = r.matched_s ? json(*r.matched_s) : json(nullptr);
  j["first_keyframe_s"] = r.first_keyframe_s ? json(*r.first_keyframe_s) : json(nullptr);
  j["goodput_fraction"] = r.wire_account ? json(r.goodput_fraction) : json(nullptr);
  j["wire_split"] = r.wire_account ? wire_account_json(*r.wire_account) : json(nullptr);
  if (!r.capture_error.empty()) j["capture_error"] = r.capture_error;
  return j;
}

json analysis_json(const ExperimentMission& m) {
  if (!m.analysis)
    return m.analysis_error.empty() ? json(nullptr) : json{{"error", m.analysis_error}};
  const MissionAnalysis& a = *m.analysis;
  return {{"keyframes", a.keyframes},
          {"analysed", a.analysed},
          {"visible_words", a.visible_words},
          {"words_read", a.words_read},
          {"words_read_in_time", a.in_time_known ? json(a.words_read_in_time) : json(nullptr)},
          {"words_reported", a.words_reported},
          {"junk", a.junk},
          {"place_matches", a.place_matches},
          {"place_matches_right", a.place_matches_right},
          {"read_words", a.read_words}};
}

// The same flight over an unlimited link (rate 0), same link kind, security and fleet size,
// preferably without adaptation: what the words read are compared with.
const ExperimentMission* unlimited_reference(const ExperimentResult& result,
                                             const ExperimentMission& m) {
  const ExperimentMission* found = nullptr;
  for (const auto& r : result.missions)
    if (r.analysis && r.profile.rate_kbit_s <= 0 && r.profile.loss_percent <= 0 &&
        r.profile.delay_ms <= 0 && r.link == m.link && r.security == m.security &&
        r.drones == m.drones && (!found || !r.link_adaptation))
      found = &r;
  return found;
}

std::string megabytes(std::uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", static_cast<double>(bytes) / 1e6);
  return text;
}

}  // namespace

void write_experiment_json(const ExperimentResult& result, const BandwidthExperimentConfig& config,
                           const std::string& path) {
  json root;
  root["experiment"] = config.name;
  root["machine"] = machine();
  root["bin_s"] = config.bin_s;
  root["scenario_dir"] = result.scenario_dir;
  root["flight_s"] = result.flight_s;
  root["words_in_time_s"] = config.words_in_time_s;
  root["skipped"] = result.skipped;
  root["interrupted"] = result.interrupted;
  root["missions"] = json::array();
  for (const auto& m : result.missions) {
    json j;
    j["name"] = m.name;
    j["link"] = m.link;
    j["security"] = m.security;
    j["link_adaptation"] = m.link_adaptation;
    j["dds_link"] = m.dds_link;
    j["profile"] = {{"name", m.profile.name},
                    {"rate_kbit_s", m.profile.rate_kbit_s},
                    {"delay_ms", m.profile.delay_ms},
                    {"loss_percent", m.profile.loss_percent}};
    j["drones"] = m.drones;
    j["dds_cap_bytes_per_s"] = m.dds_cap_bytes_per_s;
    j["ok"] = m.ok;
    j["wall_s"] = m.wall_s;
    j["run_dir"] = m.run_dir;
    j["failures"] = m.failures;
    j["notes"] = m.notes;
    j["robots"] = json::array();
    for (const auto& r : m.robots) j["robots"].push_back(robot_json(r));
    j["analysis"] = analysis_json(m);
    const ExperimentMission* reference = m.analysis ? unlimited_reference(result, m) : nullptr;
    j["words_read_vs_unlimited"] = reference && reference->analysis->words_read > 0
                                       ? json(static_cast<double>(m.analysis->words_read) /
                                              static_cast<double>(reference->analysis->words_read))
                                       : json(nullptr);
    root["missions"].push_back(j);
  }
  std::ofstream out(path);
  out << root.dump(2) << "\n";
  if (!out) throw StartupError("cannot write " + path);
}

void write_experiment_csv(const ExperimentResult& result, const std::string& path) {
  std::ofstream out(path);
  out << "mission,link,profile,rate_kbit_s,drones,robot_id,delivered,latency_median_ms,"
         "latency_p95_ms,dropped,resent,refused_writes,payload_bytes,sent_bytes,wire_tx_bytes,"
         "throughput_bytes_per_s,stream_all_bytes,stream_all_estimated,vslam_keyframe_bytes,"
         "saving_vs_stream_all,saving_vs_vslam,mission_ok\n";
  for (const auto& m : result.missions)
    for (const auto& r : m.robots) {
      const RobotMetrics& x = r.metrics;
      out << m.name << "," << m.link << "," << m.profile.name << "," << m.profile.rate_kbit_s << ","
          << m.drones << "," << x.robot_id << "," << x.delivered << ","
          << (r.latency_measured ? std::to_string(x.latency_median_ms) : "") << ","
          << (r.latency_measured ? std::to_string(x.latency_p95_ms) : "") << "," << x.dropped << ","
          << x.resent << "," << x.refused_writes << "," << x.payload_bytes << "," << x.sent_bytes
          << "," << (x.wire ? std::to_string(x.wire->tx_bytes) : "not measured") << ","
          << x.throughput_bytes_per_s << "," << x.stream_all_bytes << ","
          << (x.stream_all_estimated ? 1 : 0) << "," << x.vslam_keyframe_bytes << ","
          << x.saving_vs_stream_all << "," << x.saving_vs_vslam << "," << (m.ok ? 1 : 0) << "\n";
    }
  if (!out) throw StartupError("cannot write " + path);
}

std::string experiment_table(const ExperimentResult& result) {
  std::string table;
  char line[512];
  std::snprintf(line, sizeof line,
                "%-32s %4s %9s %7s %9s %8s %7s %7s %9s %10s %10s %8s %8s %8s %7s %7s %9s %6s "
                "%8s\n",
                "mission", "ok", "delivered", "undeliv", "lat.med", "lat.p95", "dropped", "resent",
                "payload", "wire", "kB/s/robot", "x stream", "x vslam", "goodput", "wire/pl",
                "1st kf", "idle B/s", "kB/kf", "reduced");
  table += line;
  for (const auto& m : result.missions) {
    std::uint64_t delivered = 0, dropped = 0, resent = 0, payload = 0, wire = 0, stream = 0,
                  vslam = 0, reduced = 0;
    bool wire_measured = !m.robots.empty();
    std::vector<double> medians, p95s, rates, goodputs, ratios, firsts, idles;
    std::uint64_t undelivered = 0;
    for (const auto& r : m.robots) {
      const RobotMetrics& x = r.metrics;
      delivered += x.delivered;
      dropped += x.dropped;
      reduced += x.reduced;
      resent += x.resent;
      payload += x.payload_bytes;
      stream += x.stream_all_bytes;
      vslam += x.vslam_keyframe_bytes;
      if (x.wire)
        wire += x.wire->tx_bytes;
      else
        wire_measured = false;
      if (r.latency_measured && x.delivered > 0) {
        medians.push_back(x.latency_median_ms);
        p95s.push_back(x.latency_p95_ms);
      }
      rates.push_back(x.throughput_bytes_per_s / 1e3);
      undelivered += r.pending + x.dropped;
      if (r.first_keyframe_s) firsts.push_back(*r.first_keyframe_s);
      if (r.wire_account) {
        goodputs.push_back(r.goodput_fraction);
        if (x.payload_bytes > 0)
          ratios.push_back(static_cast<double>(r.wire_account->tx.total().bytes) /
                           static_cast<double>(x.payload_bytes));
        if (r.wire_account->quiet_window) idles.push_back(r.wire_account->quiet_tx_bytes_per_s);
      }
    }
    // Per robot medians of the link figures; "-" where nothing was measured.
    const auto cell = [](const std::vector<double>& values, const char* format) {
      char text[32] = "-";
      if (!values.empty()) std::snprintf(text, sizeof text, format, median(values));
      return std::string(text);
    };
    // Fleet figures: the median robot's latency, the worst robot's p95.
    const double p95 = p95s.empty() ? 0 : *std::max_element(p95s.begin(), p95s.end());
    std::snprintf(
        line, sizeof line,
        "%-32s %4s %9llu %7llu %7.0fms %6.0fms %7llu %7llu %7sMB %8s%s %10.1f %7.1fx %7.1fx %8s "
        "%7s %7s %9s %6.1f %8llu\n",
        m.name.c_str(), m.ok ? "yes" : "NO", static_cast<unsigned long long>(delivered),
        static_cast<unsigned long long>(undelivered), median(medians), p95,
        static_cast<unsigned long long>(dropped), static_cast<unsigned long long>(resent),
        megabytes(payload).c_str(), wire_measured ? megabytes(wire).c_str() : "not meas.",
        wire_measured ? "MB" : "", median(rates), saving_ratio(stream, payload),
        saving_ratio(vslam, payload), cell(goodputs, "%.2f").c_str(), cell(ratios, "%.2f").c_str(),
        cell(firsts, "%.1fs").c_str(), cell(idles, "%.0f").c_str(),
        delivered > 0 ? static_cast<double>(payload) / static_cast<double>(delivered) / 1e3 : 0.0,
        static_cast<unsigned long long>(reduced));
    table += line;
  }
  return table + analysis_table(result);
}

std::string analysis_table(const ExperimentResult& result) {
  const bool any = std::any_of(result.missions.begin(), result.missions.end(),
                               [](const ExperimentMission& m) { return m.analysis.has_value(); });
  if (!any) return {};
  std::string table =
      "\nthe station's analysis against the scenario's truth (in time: words read in keyframes "
      "stored within words_in_time_s of capture):\n";
  char line[256];
  std::snprintf(line, sizeof line, "%-32s %9s %8s %12s %8s %13s %6s %14s %11s\n", "mission",
                "keyframes", "analysed", "words read", "in time", "vs unlimited", "junk",
                "place matches", "kB/s/drone");
  table += line;
  for (const auto& m : result.missions) {
    if (!m.analysis) {
      if (!m.analysis_error.empty()) table += m.name + ": " + m.analysis_error + "\n";
      continue;
    }
    const MissionAnalysis& a = *m.analysis;
    const ExperimentMission* reference = unlimited_reference(result, m);
    char versus[32] = "-";
    if (reference && reference->analysis->words_read > 0)
      std::snprintf(versus, sizeof versus, "%.0f %%",
                    100.0 * static_cast<double>(a.words_read) /
                        static_cast<double>(reference->analysis->words_read));
    std::uint64_t payload = 0;
    for (const auto& r : m.robots) payload += r.metrics.payload_bytes;
    char rate[32] = "-";
    if (result.flight_s > 0 && m.drones > 0)
      std::snprintf(rate, sizeof rate, "%.1f",
                    static_cast<double>(payload) / 1e3 / m.drones / result.flight_s);
    char words[32], places[32];
    std::snprintf(words, sizeof words, "%zu of %zu", a.words_read, a.visible_words);
    std::snprintf(places, sizeof places, "%zu (%zu right)", a.place_matches, a.place_matches_right);
    const std::string in_time = a.in_time_known ? std::to_string(a.words_read_in_time) : "-";
    std::snprintf(line, sizeof line, "%-32s %9zu %8zu %12s %8s %13s %6zu %14s %11s\n",
                  m.name.c_str(), a.keyframes, a.analysed, words, in_time.c_str(), versus, a.junk,
                  places, rate);
    table += line;
  }
  return table;
}

}  // namespace keyfleet::mission
