#include "keyfleet/station/station_runtime.hpp"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "keyfleet/common/clock.hpp"
#include "keyfleet/common/file_output.hpp"
#include "keyfleet/common/run_folder_lock.hpp"
#include "keyfleet/common/security_files.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleet/station/analysis_exports.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/bandwidth_report.hpp"
#include "keyfleet/station/ground_station.hpp"
#include "keyfleet/station/keyframe_analyzer.hpp"
#include "keyfleet/station/station_analysis.hpp"
#include "keyfleet/station/web/dashboard_server.hpp"

namespace keyfleet::station {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Before anything is made: a secured station without usable credentials does not start, and
// leaves no run folder behind.
std::optional<FleetRoster> checked_roster(const DdsSecurity& security) {
  require_security_credentials(security, kStationIdentity);
  if (!security.enabled) return std::nullopt;
  return read_fleet_roster(security.directory);
}

// The run folder exists before its lock is taken.
std::string made_folder(const std::string& run_dir) {
  fs::create_directories(run_dir);
  return run_dir;
}

void log_start(const StationConfig& config, const std::optional<FleetRoster>& roster,
               const Logger& logger) {
  // The dashboard's token is a secret: only the printed URL and dashboard.url carry it.
  StationConfig shown = config;
  if (!shown.dashboard.token.empty()) shown.dashboard.token = "(set, not shown)";
  logger->info("effective configuration:\n{}", to_yaml(shown));
  if (roster) {
    logger->info("DDS-Security on: {} robot(s) on the fleet's roster, {} withdrawn",
                 roster->robots.size(), roster->withdrawn.size());
    for (const auto& id : config.limits.allowed_robots)
      if (!roster->has(id))
        logger->warn("limits.allowed_robots: '{}' has no identity in the fleet: it is refused", id);
  } else {
    logger->warn(
        "DDS-Security is off (dds.security.enabled: false): anyone who reaches the network can "
        "read the fleet's keyframes and send keyframes as any robot; the report says so");
  }
}

}  // namespace

StationLinkFactory dds_station_link_factory() {
  return [](const DdsSettings& settings, Logger logger, std::shared_ptr<RobotAdmission> admission) {
    return make_dds_station_link(settings, std::move(logger), std::move(admission));
  };
}

// Declared in the order they are made, so that they go in the reverse one: the dashboard and
// the analysis before the stores they read, the link before the admission it asks.
struct StationRuntime::Parts {
  Parts(StationConfig c, const StationFolders& f)
      : config(std::move(c)),
        folders(f),
        roster(checked_roster(config.dds.security)),
        lock(made_folder(folders.run_dir), "station.lock"),
        logger(make_logger("station", config.log_level, folders.log_file)),
        report_space(fs::path(folders.run_dir) / "report.reserve", config.report_reserve_bytes),
        store((fs::path(folders.run_dir) / config.database).string()),
        mission_log((fs::path(folders.run_dir) / config.mission_log).string()) {}

  StationConfig config;
  StationFolders folders;
  std::optional<FleetRoster> roster;
  RunFolderLock lock;
  Logger logger;
  DiskReserve report_space;
  KeyframeStore store;
  MissionLog mission_log;
  // One admission for the link (which robots' topics are read) and the station (whose samples
  // are handled).
  std::shared_ptr<RobotAdmission> admission;
  std::unique_ptr<StationLink> link;
  std::unique_ptr<GroundStation> station;
  std::unique_ptr<PlaceRecognizer> places;
  std::unique_ptr<AnalysisStore> analysis_store;
  std::unique_ptr<AnalysisAttempts> attempts;
  TopoMap map;
  std::unique_ptr<AnalysisPool> pool;
  std::unique_ptr<StationAnalysis> analysis;
  // The dashboard reads the database and the pool's counters on its own threads.
  std::unique_ptr<web::DashboardServer> dashboard;
  std::string dashboard_url;
  Clock::time_point next_report;
  double start_cpu_s = 0;        // the process's CPU (all threads) when it was ready
  std::string text_engine_note;  // the report's line where the fallback engine reads
  bool finished = false;
};

StationRuntime::StationRuntime(StationConfig config, const StationFolders& folders,
                               const StationLinkFactory& make_link)
    : parts_(std::make_unique<Parts>(std::move(config), folders)) {
  Parts& p = *parts_;
  const StationConfig& c = p.config;
  route_fastdds_log(p.logger);
  log_start(c, p.roster, p.logger);
  if (!p.report_space.problem().empty())
    p.logger->warn("space for the reports: {} (the disk is nearly full)", p.report_space.problem());
  p.admission = std::make_shared<RobotAdmission>(c.limits, p.logger, p.roster);
  p.link = make_link(c.dds, p.logger, p.admission);
  p.station = std::make_unique<GroundStation>(c.limits, p.store, p.mission_log, *p.link, p.logger,
                                              p.admission);

  // Analysis behind the reader: engines first (start-up errors surface here), then the pool.
  const AnalysisConfig& analysis = c.analysis;
  p.places = make_configured_place_recognizer(analysis.places);
  std::vector<AnalysisPool::Step> steps;
  TextReadingConfig text = analysis.text;  // its engine the fallback where ppocr's are missing
  for (int i = 0; i < analysis.workers; ++i) {
    auto analyzer = std::make_shared<KeyframeAnalyzer>(
        make_station_text_reader(text, p.logger), p.places.get(),
        make_configured_place_describer(analysis.places), analysis, p.logger);
    steps.push_back([analyzer](const AnalysisJob& job) { return analyzer->analyse(job); });
  }
  if (text.engine != analysis.text.engine)
    p.text_engine_note = "  text read with '" + text.engine + "', not '" + analysis.text.engine +
                         "': its models are not installed (the log says which; " +
                         "scripts/fetch_ppocr.sh)\n";
  p.analysis_store = std::make_unique<AnalysisStore>(p.store.path());
  p.attempts = std::make_unique<AnalysisAttempts>(p.store.path());
  p.pool = std::make_unique<AnalysisPool>(
      std::move(steps), static_cast<std::size_t>(analysis.queue_capacity), p.logger,
      [attempts = p.attempts.get()](const KeyframeKey& key) { attempts->started(key); });
  p.analysis =
      std::make_unique<StationAnalysis>(p.store, *p.analysis_store, p.map, *p.pool, p.logger);
  p.analysis->skip_abandoned(*p.attempts, analysis.max_attempts);
  p.analysis->restore(p.places.get(),
                      retrieval_mode(analysis.places.retrieval).ranks_by_descriptor());

  const fs::path url_file = fs::path(p.folders.run_dir) / "dashboard.url";
  fs::remove(url_file);
  if (c.dashboard.enabled) {
    p.dashboard = std::make_unique<web::DashboardServer>(
        c.dashboard, p.store.path(),
        [pool = p.pool.get()] { return std::optional(pool->counters()); }, p.logger);
    // Written whole, then renamed: `keyfleet mission` reads it while the station runs. The URL
    // may hold the token: the file is the owner's alone.
    p.dashboard_url = p.dashboard->url();
    write_file(url_file, p.dashboard_url + "\n");
    std::error_code mode_error;
    fs::permissions(url_file, fs::perms::owner_read | fs::perms::owner_write,
                    fs::perm_options::replace, mode_error);
    if (mode_error)
      p.logger->warn("cannot make {} private: {}", url_file.string(), mode_error.message());
    // The token (configured or generated) stays out of the log.
    p.logger->info("dashboard at {}{}", p.dashboard_url.substr(0, p.dashboard_url.find('?')),
                   p.dashboard_url.find("?token=") == std::string::npos
                       ? ""
                       : " (with its token: see dashboard.url)");
  }
  p.station->on_stored([analysis = p.analysis.get(), dashboard = p.dashboard.get()](
                           const Keyframe& k, const cv::Mat& decoded) {
    analysis->on_stored(k, decoded);
    if (dashboard) dashboard->poke();
  });

  p.mission_log.event("station started", wall_time_ns());
  p.start_cpu_s = process_cpu_s();
  p.logger->info("station ready: {} keyframe(s) already in {} ({:.2f} s of CPU to start)",
                 p.store.keyframe_count(), p.store.path(), p.start_cpu_s);
  p.next_report = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(c.report_period_s));
}

StationRuntime::~StationRuntime() = default;

std::size_t StationRuntime::step(std::chrono::milliseconds wait) {
  Parts& p = *parts_;
  const std::size_t taken = p.station->step(wait);
  if (p.analysis->step() > 0 && p.dashboard) p.dashboard->poke();
  if (Clock::now() >= p.next_report) {
    const auto report = build_bandwidth_report(p.store.totals());
    p.logger->info("{} robot(s), {} keyframes stored, {} bytes received", report.robots.size(),
                   report.fleet.keyframes_stored, report.fleet.bytes_received);
    p.next_report = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(p.config.report_period_s));
  }
  return taken;
}

int StationRuntime::run(const StopToken& stop) {
  while (!stop.requested()) step(std::chrono::milliseconds(100));
  return finish();
}

int StationRuntime::finish() {
  Parts& p = *parts_;
  if (p.finished) return 0;
  p.finished = true;
  // Drain what already arrived before leaving.
  while (p.station->step(std::chrono::milliseconds(0)) > 0) {
  }
  const double drain_s = p.config.analysis.drain_timeout_s;
  if (!p.analysis->drain(std::chrono::milliseconds(static_cast<long>(drain_s * 1000))))
    p.logger->warn("analysis not finished within {} s; the rest is analysed at the next start",
                   drain_s);
  p.pool->stop();
  p.analysis->step();
  if (p.dashboard) {
    p.dashboard->stop();
    fs::remove(fs::path(p.folders.run_dir) / "dashboard.url");
  }
  // Each report on its own: one that cannot be written (a full disk) does not stop the others.
  p.report_space.release();
  std::string table;
  bool reports_written = true;
  const auto write_report = [&](const char* what, const std::function<std::string()>& write) {
    try {
      table += write();
    } catch (const std::exception& e) {
      p.logger->error("{} not written: {}", what, e.what());
      reports_written = false;
    }
  };
  write_report("the mission log's last event", [&] {
    p.mission_log.event("station stopped", wall_time_ns());
    return std::string();
  });
  write_report("the bandwidth report", [&] {
    auto report = build_bandwidth_report(p.store.totals());
    report.refused = p.admission->refusals();
    report.dds_security = p.config.dds.security.enabled;
    return write_bandwidth_report(report, p.folders.run_dir);
  });
  write_report("the analysis exports", [&] {
    return "\n" +
           write_analysis_exports(*p.analysis_store, p.map, p.analysis->summary(),
                                  p.folders.run_dir) +
           p.text_engine_note;
  });
  write_report("report.txt", [&] {
    write_file(fs::path(p.folders.run_dir) / "report.txt", table);
    return std::string();
  });
  // The process's CPU, all threads: to start (models, DDS, the database) and in all, so that a
  // benchmark can tell the start from the work; and whether its analysis kept up with the
  // keyframes: how long they waited for it, and how many a full queue deferred to later
  // (`keyfleet bench fleet`).
  write_report("process.json", [&] {
    const AnalysisPool::Latency lag = p.pool->latency();
    char text[256];
    std::snprintf(text, sizeof text,
                  "{\"start_cpu_s\": %.3f, \"cpu_s\": %.3f, \"analysis_latency_s\": "
                  "{\"count\": %zu, \"p50\": %.3f, \"p95\": %.3f, \"max\": %.3f}, "
                  "\"analysis_deferred\": %zu}\n",
                  p.start_cpu_s, process_cpu_s(), lag.count, lag.p50_s, lag.p95_s, lag.max_s,
                  p.pool->counters().deferred);
    write_file(fs::path(p.folders.run_dir) / "process.json", text);
    return std::string();
  });
  std::cout << table << std::flush;
  return reports_written ? 0 : 1;
}

const std::string& StationRuntime::dashboard_url() const { return parts_->dashboard_url; }

std::string StationRuntime::report_path() const {
  return (fs::path(parts_->folders.run_dir) / "report.json").string();
}

const Logger& StationRuntime::logger() const { return parts_->logger; }

}  // namespace keyfleet::station
