#include "keyfleet/mission/fleet_bench.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>
#include <thread>

#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/mission/mission_config.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/vision/cpu_class.hpp"

namespace keyfleet::mission {
namespace {

namespace fs = std::filesystem;

double per(double total, double count) { return count > 0 ? total / count : 0; }

StationFigures read_station(const ProcessFigures& station) {
  StationFigures figures;
  figures.cpu_s = station.cpu_s;
  try {
    std::ifstream in(fs::path(station.run_dir) / "process.json");
    if (in) {
      const auto process = nlohmann::json::parse(in);
      figures.start_cpu_s = process.value("start_cpu_s", 0.0);
      const auto lag = process.value("analysis_latency_s", nlohmann::json::object());
      if (lag.value("count", 0) > 0) {
        figures.read_lag_p95_s = lag.value("p95", -1.0);
        figures.read_lag_max_s = lag.value("max", -1.0);
      }
      figures.deferred = process.value("analysis_deferred", std::int64_t(-1));
    }
  } catch (const nlohmann::json::exception&) {
    // A station that stopped while writing it: its whole CPU only.
  }
  const fs::path database = fs::path(station.run_dir) / "station.sqlite";
  if (!fs::exists(database)) return figures;
  try {
    SqliteDb db(database.string(), SqliteDb::Mode::kReadOnly);
    auto query = db.prepare(
        "SELECT COUNT(*), COALESCE(SUM(text_ms), 0), COALESCE(SUM(places_ms), 0), "
        "COALESCE(SUM(text_cpu_ms), 0) "
        "FROM keyframe_analysis WHERE status = 'done'");
    if (query.step()) {
      figures.keyframes = std::uint64_t(query.int64(0));
      figures.text_ms = query.real(1);
      figures.text_cpu_ms = query.real(3);
      figures.places_ms = query.real(2);
    }
  } catch (const SqliteError&) {
    // A station without analysis has no such table: CPU only.
  }
  return figures;
}

// `j` to `path` whole: written beside it, then renamed over it (a reader never sees half).
void write_json_file(const fs::path& path, const nlohmann::json& j) {
  const fs::path partial = path.string() + ".partial";
  {
    std::ofstream out(partial);
    out << j.dump(2) << "\n";
    if (!out) throw std::runtime_error("cannot write " + partial.string());
  }
  fs::rename(partial, path);
}

std::string timestamp() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", std::localtime(&now));
  return text;
}

}  // namespace

AgentStreamFigures read_stream_summary(const std::string& path, const std::string& robot_id) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": missing (the agent wrote no stream summary)");
  try {
    const auto j = nlohmann::json::parse(in);
    AgentStreamFigures f;
    f.robot_id = robot_id;
    f.frames = j.at("frames").get<std::uint64_t>();
    f.fps = j.at("fps").get<double>();
    f.stream_s = j.at("stream_s").get<double>();
    f.late_frames = j.at("late_frames").get<std::uint64_t>();
    f.max_lag_ms = j.at("max_lag_ms").get<double>();
    f.process_cpu_s = j.at("process_cpu_s").get<double>();
    f.stream_cpu_s = j.value("stream_cpu_s", 0.0);
    for (const auto& [stage, t] : j.at("stages").items())
      f.stages[stage] = {stage, t.at("cpu_ms").get<double>(), t.at("calls").get<std::uint64_t>()};
    return f;
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

FleetRunFigures fleet_figures(int drones, bool realtime,
                              const std::vector<AgentStreamFigures>& agents,
                              const StationFigures& station, double wall_s, unsigned cores,
                              double realtime_threshold) {
  FleetRunFigures r;
  r.drones = drones;
  r.realtime = realtime;
  r.wall_s = wall_s;
  double agent_cpu_s = 0, stream_cpu_s = 0;
  std::map<std::string, double> stage_ms;
  r.rtf_min = agents.empty() ? 0 : 1e9;
  for (const auto& a : agents) {
    const double rtf = per(double(a.frames) / std::max(a.fps, 1e-9), a.stream_s);
    r.rtf_min = std::min(r.rtf_min, rtf);
    r.rtf_mean += rtf / double(agents.size());
    r.frames += a.frames;
    r.late_frames += a.late_frames;
    r.max_lag_ms = std::max(r.max_lag_ms, a.max_lag_ms);
    agent_cpu_s += a.process_cpu_s;
    stream_cpu_s += a.stream_cpu_s;
    for (const auto& [name, t] : a.stages) stage_ms[name] += t.cpu_ms_total;
  }
  const double frames = double(r.frames);
  r.agent_cpu_ms_per_frame = per(1e3 * agent_cpu_s, frames);
  r.agent_stream_cpu_ms_per_frame = per(1e3 * stream_cpu_s, frames);
  for (const auto& [name, ms] : stage_ms) r.stage_ms_per_frame[name] = per(ms, frames);
  r.station_cpu_ms_per_frame = per(1e3 * station.cpu_s, frames);
  r.station_work_cpu_ms_per_frame =
      per(1e3 * std::max(0.0, station.cpu_s - station.start_cpu_s), frames);
  r.station_keyframes = station.keyframes;
  r.station_text_ms_per_keyframe = per(station.text_ms, double(station.keyframes));
  r.station_places_ms_per_keyframe = per(station.places_ms, double(station.keyframes));
  r.station_text_cpu_ms_per_keyframe = per(station.text_cpu_ms, double(station.keyframes));
  r.station_read_lag_p95_s = station.read_lag_p95_s;
  r.station_read_lag_max_s = station.read_lag_max_s;
  r.station_deferred = station.deferred;
  r.frames_per_s_per_core = per(per(frames, wall_s), double(std::max(cores, 1u)));
  r.keeps_realtime = realtime && !agents.empty() && r.rtf_min >= realtime_threshold;
  return r;
}

std::optional<int> largest_realtime(const std::vector<FleetRunFigures>& runs) {
  std::vector<const FleetRunFigures*> sorted;
  for (const auto& r : runs)
    if (r.realtime) sorted.push_back(&r);
  std::sort(sorted.begin(), sorted.end(),
            [](const auto* a, const auto* b) { return a->drones < b->drones; });
  std::optional<int> largest;
  for (const auto* r : sorted) {
    if (!r->keeps_realtime || !r->failures.empty()) break;
    largest = r->drones;
  }
  return largest;
}

std::string format_fleet_table(const std::vector<FleetRunFigures>& runs, unsigned cores) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line,
                "%-9s %3s %7s %6s %6s %7s %7s %8s %9s %9s %9s %9s %8s %9s %9s %12s %9s %s\n",
                "mode", "N", "wall s", "RTF", "RTFmin", "frames", "late", "lag ms", "agent ms/f",
                "strm ms/f", "stn ms/f", "stn work", "stn kf", "OCR ms/kf", "OCR cpu",
                "read p95+dfr", "fps/core", "real time");
  out += line;
  std::set<std::string> stages;
  for (const auto& r : runs) {
    for (const auto& [name, ms] : r.stage_ms_per_frame) stages.insert(name);
    char read_lag[32] = "-";  // a station that wrote no analysis latency
    if (r.station_read_lag_p95_s >= 0 && r.station_deferred > 0)
      std::snprintf(read_lag, sizeof read_lag, "%.1f+%lld", r.station_read_lag_p95_s,
                    static_cast<long long>(r.station_deferred));
    else if (r.station_read_lag_p95_s >= 0)
      std::snprintf(read_lag, sizeof read_lag, "%.1f", r.station_read_lag_p95_s);
    std::snprintf(
        line, sizeof line,
        "%-9s %3d %7.1f %6.2f %6.2f %7llu %7llu %8.0f %9.2f %9.2f %9.2f %9.2f %8llu %9.0f "
        "%9.0f %12s %9.1f %s\n",
        r.realtime ? "realtime" : "fast", r.drones, r.wall_s, r.rtf_mean, r.rtf_min,
        static_cast<unsigned long long>(r.frames), static_cast<unsigned long long>(r.late_frames),
        r.max_lag_ms, r.agent_cpu_ms_per_frame, r.agent_stream_cpu_ms_per_frame,
        r.station_cpu_ms_per_frame, r.station_work_cpu_ms_per_frame,
        static_cast<unsigned long long>(r.station_keyframes), r.station_text_ms_per_keyframe,
        r.station_text_cpu_ms_per_keyframe, read_lag, r.frames_per_s_per_core,
        !r.realtime ? "-" : (r.keeps_realtime && r.failures.empty() ? "yes" : "NO"));
    out += line;
  }
  out +=
      "\nagents' CPU per frame per stage (ms, calling thread; 'source' = reading and decoding)\n";
  std::snprintf(line, sizeof line, "%-9s %3s", "mode", "N");
  out += line;
  for (const auto& s : stages) {
    std::snprintf(line, sizeof line, " %11s", s.c_str());
    out += line;
  }
  out += "\n";
  for (const auto& r : runs) {
    std::snprintf(line, sizeof line, "%-9s %3d", r.realtime ? "realtime" : "fast", r.drones);
    out += line;
    for (const auto& s : stages) {
      const auto it = r.stage_ms_per_frame.find(s);
      std::snprintf(line, sizeof line, " %11.3f",
                    it == r.stage_ms_per_frame.end() ? 0.0 : it->second);
      out += line;
    }
    out += "\n";
  }
  const auto largest = largest_realtime(runs);
  std::snprintf(line, sizeof line, "\n%u cores; largest N at real time: %s\n", cores,
                largest ? std::to_string(*largest).c_str() : "none of those run");
  out += line;
  return out;
}

std::string fleet_cpu_lines(const MissionConfig& mission) {
  const SemanticConfig& semantic = mission.agent.selector.semantic;
  const bool reader_int8 = mission.station.analysis.text.ppocr.int8;
  return vision::cpu_class_line() + "\nthe agents' semantic model: " +
         vision::segmenter_kernels(semantic.bfloat16, semantic.int8) +
         " (semantic.bfloat16: " + (semantic.bfloat16 ? "true" : "false") +
         ", int8: " + (semantic.int8 ? "true" : "false") +
         ")\nthe station's reader: " + vision::segmenter_kernels(false, reader_int8) +
         " (analysis.text.ppocr_int8: " + (reader_int8 ? "true" : "false") + ")";
}

nlohmann::json fleet_json(const std::vector<FleetRunFigures>& runs, unsigned cores,
                          const std::string& cpu) {
  const auto written = [](double v) { return v >= 0 ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json out = {{"cores", cores}, {"cpu", cpu}, {"runs", nlohmann::json::array()}};
  const auto largest = largest_realtime(runs);
  out["largest_realtime"] = largest ? nlohmann::json(*largest) : nlohmann::json();
  for (const FleetRunFigures& r : runs)
    out["runs"].push_back({
        {"drones", r.drones},
        {"realtime", r.realtime},
        {"wall_s", r.wall_s},
        {"rtf_min", r.rtf_min},
        {"rtf_mean", r.rtf_mean},
        {"frames", r.frames},
        {"late_frames", r.late_frames},
        {"max_lag_ms", r.max_lag_ms},
        {"agent_cpu_ms_per_frame", r.agent_cpu_ms_per_frame},
        {"agent_stream_cpu_ms_per_frame", r.agent_stream_cpu_ms_per_frame},
        {"stage_ms_per_frame", r.stage_ms_per_frame},
        {"station_cpu_ms_per_frame", r.station_cpu_ms_per_frame},
        {"station_work_cpu_ms_per_frame", r.station_work_cpu_ms_per_frame},
        {"station_keyframes", r.station_keyframes},
        {"station_text_ms_per_keyframe", r.station_text_ms_per_keyframe},
        {"station_places_ms_per_keyframe", r.station_places_ms_per_keyframe},
        {"station_text_cpu_ms_per_keyframe", r.station_text_cpu_ms_per_keyframe},
        {"station_read_lag_p95_s", written(r.station_read_lag_p95_s)},
        {"station_read_lag_max_s", written(r.station_read_lag_max_s)},
        {"station_deferred",
         r.station_deferred >= 0 ? nlohmann::json(r.station_deferred) : nlohmann::json()},
        {"frames_per_s_per_core", r.frames_per_s_per_core},
        {"keeps_realtime", r.keeps_realtime},
        {"failures", r.failures},
    });
  return out;
}

std::vector<FleetRunFigures> run_fleet_bench(const FleetBenchOptions& o,
                                             const MissionBinaries& binaries, Logger logger,
                                             std::ostream& progress, const StopToken& stop) {
  MissionConfig base = load_mission_config(o.mission_config);
  if (o.drones.empty()) throw std::invalid_argument("no fleet sizes to run");
  const int most = *std::max_element(o.drones.begin(), o.drones.end());
  const fs::path root = fs::absolute(o.out) / ("fleet-" + timestamp());
  std::string scenario_dir = o.scenario_dir.empty() ? base.scenario_dir : o.scenario_dir;
  if (scenario_dir.empty()) {
    if (base.scenario.empty())
      throw std::invalid_argument(o.mission_config + ": names no scenario to fly");
    ScenarioConfig scenario = load_scenario_config(base.scenario);
    scenario.drones.count = std::max(scenario.drones.count, most);
    if (o.frames > 0) scenario.frames_per_drone = o.frames;
    scenario_dir = (root / "scenario").string();
    progress << "generating " << scenario.drones.count << " drones x " << scenario.frames_per_drone
             << " frames into " << scenario_dir << " ...\n"
             << std::flush;
    scenario::generate_scenario(scenario, scenario_dir, logger);
  }
  const std::size_t available = scenario::read_scenario(scenario_dir).drones.size();
  if (available < std::size_t(most))
    throw std::invalid_argument(scenario_dir + " has " + std::to_string(available) +
                                " drones; the largest fleet asked for is " + std::to_string(most));
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());

  std::vector<FleetRunFigures> runs;
  std::vector<bool> modes;
  if (o.realtime) modes.push_back(true);
  if (o.fast) modes.push_back(false);
  for (const bool realtime : modes) {
    for (const int n : o.drones) {
      if (stop.requested()) return runs;
      MissionConfig mission = base;
      mission.name = std::string("fleet-") + (realtime ? "rt" : "fast") + "-" + std::to_string(n);
      mission.run_root = root.string();
      mission.scenario.clear();
      mission.scenario_dir = scenario_dir;
      mission.scenario_drones = n;
      mission.agent.source.realtime = realtime;
      if (o.trigger) mission.agent.selector.trigger.kind = *o.trigger;
      progress << "\n== " << n << " agent(s) + station, "
               << (realtime ? "real time" : "as fast as possible") << "\n"
               << std::flush;
      MissionRunner runner(mission, binaries, logger, progress);
      const MissionResult result = runner.run(stop);
      std::vector<AgentStreamFigures> agents;
      std::vector<std::string> failures = result.failures;
      for (const auto& a : result.agents) {
        try {
          agents.push_back(
              read_stream_summary((fs::path(a.run_dir) / "stream.json").string(), a.name));
          agents.back().process_cpu_s = a.cpu_s;  // wait4's figure includes the drain
        } catch (const std::exception& e) {
          failures.push_back(e.what());
        }
      }
      runs.push_back(fleet_figures(n, realtime, agents, read_station(result.station),
                                   result.agents_wall_s, cores, o.realtime_threshold));
      runs.back().failures = failures;
      progress << format_fleet_table({runs.back()}, cores) << std::flush;
      write_json_file(root / "fleet.json", fleet_json(runs, cores, fleet_cpu_lines(base)));
    }
  }
  if (!runs.empty()) progress << "\nevery figure: " << (root / "fleet.json").string() << "\n";
  return runs;
}

}  // namespace keyfleet::mission
