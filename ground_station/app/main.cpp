// ground_station: composition root of the station that stores the fleet's keyframes.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>
#include <iostream>

#include "keyfleet/cli/process_options.hpp"
#include "keyfleet/common/clock.hpp"
#include "keyfleet/common/file_output.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/common/run_folder_lock.hpp"
#include "keyfleet/common/security_files.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleet/station/analysis_exports.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/bandwidth_report.hpp"
#include "keyfleet/station/ground_station.hpp"
#include "keyfleet/station/keyframe_analyzer.hpp"
#include "keyfleet/station/station_analysis.hpp"
#include "keyfleet/station/web/dashboard_server.hpp"

namespace {

using namespace keyfleet;
namespace fs = std::filesystem;

int run(const ProcessOptions& options) {
  StationConfig config = load_station_config(options.config_path);
  apply_dds_overrides(options, config.dds);
  // Before anything is made: without usable credentials a secured station does not start.
  require_security_credentials(config.dds.security, kStationIdentity);
  std::optional<FleetRoster> roster;
  if (config.dds.security.enabled) roster = read_fleet_roster(config.dds.security.directory);
  fs::create_directories(options.run_dir);
  const RunFolderLock run_folder(options.run_dir, "station.lock");

  Logger logger = make_logger("station", config.log_level, options.log_file);
  route_fastdds_log(logger);
  {
    // The dashboard's token is a secret: only the printed URL and dashboard.url carry it.
    StationConfig shown = config;
    if (!shown.dashboard.token.empty()) shown.dashboard.token = "(set, not shown)";
    logger->info("effective configuration:\n{}", to_yaml(shown));
  }
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

  ShutdownSignal shutdown;
  DiskReserve report_space(fs::path(options.run_dir) / "report.reserve",
                           config.report_reserve_bytes);
  if (!report_space.problem().empty())
    logger->warn("space for the reports: {} (the disk is nearly full)", report_space.problem());
  station::KeyframeStore store((fs::path(options.run_dir) / config.database).string());
  station::MissionLog mission_log((fs::path(options.run_dir) / config.mission_log).string());
  // One admission for the link (which robots' topics are read) and the station (whose samples
  // are handled).
  auto admission = std::make_shared<RobotAdmission>(config.limits, logger, roster);
  auto link = make_dds_station_link(config.dds, logger, admission);
  station::GroundStation station(config.limits, store, mission_log, *link, logger, admission);

  // Analysis behind the reader: engines first (start-up errors surface here), then the pool.
  const AnalysisConfig& analysis_config = config.analysis;
  auto places = station::make_configured_place_recognizer(analysis_config.places);
  std::vector<station::AnalysisPool::Step> steps;
  for (int i = 0; i < analysis_config.workers; ++i) {
    auto analyzer = std::make_shared<station::KeyframeAnalyzer>(
        station::make_configured_text_reader(analysis_config.text), places.get(),
        station::make_configured_place_describer(analysis_config.places), analysis_config, logger);
    steps.push_back([analyzer](const station::AnalysisJob& job) { return analyzer->analyse(job); });
  }
  station::AnalysisStore analysis_store(store.path());
  station::AnalysisAttempts attempts(store.path());
  station::TopoMap map;
  station::AnalysisPool pool(
      std::move(steps), static_cast<std::size_t>(analysis_config.queue_capacity), logger,
      [&attempts](const station::KeyframeKey& key) { attempts.started(key); });
  station::StationAnalysis analysis(store, analysis_store, map, pool, logger);
  analysis.skip_abandoned(attempts, analysis_config.max_attempts);
  analysis.restore(places.get(),
                   station::retrieval_mode(analysis_config.places.retrieval).ranks_by_descriptor());

  // The dashboard reads the database on its own threads; the pool outlives it.
  std::unique_ptr<station::web::DashboardServer> dashboard;
  const fs::path url_file = fs::path(options.run_dir) / "dashboard.url";
  fs::remove(url_file);
  if (config.dashboard.enabled) {
    dashboard = std::make_unique<station::web::DashboardServer>(
        config.dashboard, store.path(), [&pool] { return std::optional(pool.counters()); }, logger);
    // Written whole, then renamed: `keyfleet mission` reads it while the station runs.
    const std::string url = dashboard->url();
    write_file(url_file, url + "\n");
    std::error_code mode_error;  // the URL may hold the token: the owner's alone
    fs::permissions(url_file, fs::perms::owner_read | fs::perms::owner_write,
                    fs::perm_options::replace, mode_error);
    if (mode_error)
      logger->warn("cannot make {} private: {}", url_file.string(), mode_error.message());
    // The token (configured or generated) stays out of the log.
    logger->info("dashboard at {}{}", url.substr(0, url.find('?')),
                 url.find("?token=") == std::string::npos ? ""
                                                          : " (with its token: see dashboard.url)");
  }
  station.on_stored([&analysis, &dashboard](const Keyframe& k) {
    analysis.on_stored(k);
    if (dashboard) dashboard->poke();
  });

  mission_log.event("station started", wall_time_ns());
  logger->info("station ready: {} keyframe(s) already in {}", store.keyframe_count(), store.path());

  using Clock = std::chrono::steady_clock;
  const auto report_period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(config.report_period_s));
  auto next_report = Clock::now() + report_period;
  while (!shutdown.stop.requested()) {
    station.step(std::chrono::milliseconds(100));
    if (analysis.step() > 0 && dashboard) dashboard->poke();
    if (Clock::now() >= next_report) {
      const auto report = station::build_bandwidth_report(store.totals());
      logger->info("{} robot(s), {} keyframes stored, {} bytes received", report.robots.size(),
                   report.fleet.keyframes_stored, report.fleet.bytes_received);
      next_report = Clock::now() + report_period;
    }
  }
  // Drain what already arrived before leaving.
  while (station.step(std::chrono::milliseconds(0)) > 0) {
  }
  const auto drain_timeout =
      std::chrono::milliseconds(static_cast<long>(analysis_config.drain_timeout_s * 1000));
  if (!analysis.drain(drain_timeout)) {
    logger->warn("analysis not finished within {} s; the rest is analysed at the next start",
                 analysis_config.drain_timeout_s);
  }
  pool.stop();
  analysis.step();
  if (dashboard) {
    dashboard->stop();
    fs::remove(url_file);
  }
  // Each report on its own: one that cannot be written (a full disk) does not stop the others.
  report_space.release();
  std::string table;
  bool reports_written = true;
  const auto write_report = [&](const char* what, const std::function<std::string()>& write) {
    try {
      table += write();
    } catch (const std::exception& e) {
      logger->error("{} not written: {}", what, e.what());
      reports_written = false;
    }
  };
  write_report("the mission log's last event", [&] {
    mission_log.event("station stopped", wall_time_ns());
    return std::string();
  });
  write_report("the bandwidth report", [&] {
    auto report = station::build_bandwidth_report(store.totals());
    report.refused = admission->refusals();
    report.dds_security = config.dds.security.enabled;
    return station::write_bandwidth_report(report, options.run_dir);
  });
  write_report("the analysis exports", [&] {
    return "\n" + station::write_analysis_exports(analysis_store, map, analysis.summary(),
                                                  options.run_dir);
  });
  write_report("report.txt", [&] {
    write_file(fs::path(options.run_dir) / "report.txt", table);
    return std::string();
  });
  std::cout << table << std::flush;
  logger->info("stopped by signal {}; report in {}", shutdown.received(),
               (fs::path(options.run_dir) / "report.json").string());
  return reports_written ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  keyfleet::limit_openmp_to_one_thread(argv);
  keyfleet::block_termination_signals();
  keyfleet::keep_created_files_private();
  keyfleet::ProcessOptions options;
  CLI::App app{"keyfleet ground station: stores and reports the fleet's keyframes"};
  keyfleet::add_process_options(app, options, "station YAML config");
  CLI11_PARSE(app, argc, argv);
  return keyfleet::run_reporting_errors("ground_station", [&] { return run(options); });
}
