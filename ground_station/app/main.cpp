// ground_station: the station that stores the fleet's keyframes. Its parts are made and run by
// keyfleet::station::StationRuntime; this only reads the options and the config.
#include <CLI/CLI.hpp>

#include "keyfleet/cli/process_options.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/common/shutdown_signal.hpp"
#include "keyfleet/station/station_runtime.hpp"

namespace {

using namespace keyfleet;

int run(const ProcessOptions& options) {
  StationConfig config = load_station_config(options.config_path);
  apply_dds_overrides(options, config.dds);
  ShutdownSignal shutdown;
  station::StationRuntime station(std::move(config), {options.run_dir, options.log_file},
                                  station::dds_station_link_factory());
  const int status = station.run(shutdown.stop);
  station.logger()->info("stopped by signal {}; report in {}", shutdown.received(),
                         station.report_path());
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  keyfleet::limit_openmp_to_one_thread(argv);
  keyfleet::block_termination_signals();
  keyfleet::keep_created_files_private();
  keyfleet::raise_open_file_limit();
  keyfleet::keep_image_buffers_in_heap();  // a keyframe's temporaries, not fresh pages each time
  keyfleet::ProcessOptions options;
  CLI::App app{"keyfleet ground station: stores and reports the fleet's keyframes"};
  keyfleet::add_process_options(app, options, "station YAML config");
  CLI11_PARSE(app, argc, argv);
  return keyfleet::run_reporting_errors("ground_station", [&] { return run(options); });
}
