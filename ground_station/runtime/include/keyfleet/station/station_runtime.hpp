#pragma once
// The whole ground station as one object, its composition root: the stores, the link, the
// analysis and the dashboard made from a StationConfig and a run folder, one synchronous step
// at a time, and the reports at the end. ground_station's main only parses its options and
// runs one; tests run one in process with a link of their own.
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/robot_admission.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/common/transport.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet::station {

// Makes the station's link to its robots, reading the topics of the robots `admission` admits.
using StationLinkFactory = std::function<std::unique_ptr<StationLink>(
    const DdsSettings& settings, Logger logger, std::shared_ptr<RobotAdmission> admission)>;

// The DDS link (keyfleet::dds): what a station uses unless a test gives another.
StationLinkFactory dds_station_link_factory();

struct StationFolders {
  std::string run_dir;   // created if missing; locked (station.lock) while the station runs
  std::string log_file;  // the log's copy on disk; empty = standard error only
};

class StationRuntime {
 public:
  // In this order: checks the DDS-Security credentials (nothing is made when they are not
  // usable), takes the run folder, then opens the log, the stores, the link, the analysis and
  // the dashboard. Throws StartupError (or ConfigError) naming what is wrong.
  StationRuntime(StationConfig config, const StationFolders& folders,
                 const StationLinkFactory& make_link);
  ~StationRuntime();
  StationRuntime(const StationRuntime&) = delete;
  StationRuntime& operator=(const StationRuntime&) = delete;

  // Takes what arrived (waiting up to `wait` when nothing has), stores and acknowledges it,
  // hands it to the analysis, updates the dashboard and, every report_period_s, logs a line.
  // Returns the keyframes taken.
  std::size_t step(std::chrono::milliseconds wait);
  // Steps until `stop` is requested, then finish().
  int run(const StopToken& stop);
  // Drains what already arrived and the analysis (up to analysis.drain_timeout_s), stops the
  // dashboard and writes every report, each on its own. 0 when all were written. Once.
  int finish();

  const std::string& dashboard_url() const;  // "" without a dashboard
  std::string report_path() const;           // <run>/report.json
  const Logger& logger() const;

 private:
  struct Parts;
  std::unique_ptr<Parts> parts_;
};

}  // namespace keyfleet::station
