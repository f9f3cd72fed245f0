// robot_agent: composition root of one robot's keyframe pipeline.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>

#include "keyfleet/agent/agent_runner.hpp"
#include "keyfleet/cli/process_options.hpp"
#include "keyfleet/common/clock.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/common/security_files.hpp"
#include "keyfleet/dds/dds_transport.hpp"

namespace {

using namespace keyfleet;

int run(const ProcessOptions& options, const std::string& robot_id) {
  AgentConfig config = load_agent_config(options.config_path);
  apply_dds_overrides(options, config.dds);
  if (!robot_id.empty()) {
    if (!is_valid_robot_id(robot_id))
      throw ConfigError("--robot-id: '" + robot_id + "' must match [A-Za-z0-9_-]{1,32}");
    config.robot_id = robot_id;
  }
  // Before anything is made: without usable credentials a secured agent does not start.
  require_security_credentials(config.dds.security, config.robot_id);
  if (config.source.kind == SourceConfig::Kind::kScenario && config.source.drone.empty())
    config.source.drone = config.robot_id;
  std::filesystem::create_directories(options.run_dir);

  Logger logger = make_logger("agent " + config.robot_id, config.log_level, options.log_file);
  route_fastdds_log(logger);
  logger->info("effective configuration:\n{}", to_yaml(config));
  if (!config.dds.security.enabled)
    logger->warn(
        "DDS-Security is off (dds.security.enabled: false): anyone who reaches the network can "
        "read this robot's keyframes and acknowledge them in the station's name");

  ShutdownSignal shutdown;
  auto source = agent::make_frame_source(config.source, logger, config.selector.decode_reduce);
  const std::filesystem::path outbox_path =
      std::filesystem::path(options.run_dir) / config.outbox.path;
  agent::Outbox outbox(outbox_path.string(), config.robot_id, config.outbox);
  if (outbox.pending() > 0)
    logger->info("outbox {} holds {} unacknowledged keyframe(s) from an earlier run", outbox.path(),
                 outbox.pending());
  agent::StageClock clock;
  auto selector = agent::make_selector(config.selector, source->fps(), &clock);
  auto link = make_dds_agent_link(config.dds, config.robot_id, logger);
  agent::KeyframeAgent pipeline(config, std::move(selector),
                                std::make_unique<JpegCodec>(config.codec.jpeg_quality), outbox,
                                *link, clock, logger);
  agent::AgentRunner runner(config, *source, pipeline, *link, clock, logger);

  const agent::AgentOutcome outcome = runner.run(shutdown.stop);
  const std::string summary_path =
      (std::filesystem::path(options.run_dir) / "stream.json").string();
  if (!agent::write_stream_summary(summary_path, runner.summary(), clock.snapshot(),
                                   process_cpu_s()))
    logger->warn("cannot write {}", summary_path);
  switch (outcome) {
    case agent::AgentOutcome::kDelivered: return 0;
    case agent::AgentOutcome::kStopped:
      logger->info("stopped by signal {}; {} keyframe(s) kept in {}", shutdown.received(),
                   outbox.pending(), outbox.path());
      return 0;
    case agent::AgentOutcome::kUndelivered:
      logger->error("{} keyframe(s) not acknowledged within drain_timeout_s={}; kept in {}",
                    outbox.pending(), config.drain_timeout_s, outbox.path());
      return 3;
  }
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  keyfleet::block_termination_signals();
  keyfleet::keep_created_files_private();
  keyfleet::keep_image_buffers_in_heap();
  keyfleet::ProcessOptions options;
  std::string robot_id;
  CLI::App app{"keyfleet robot agent: selects keyframes from a camera stream and publishes them"};
  keyfleet::add_process_options(app, options, "agent YAML config");
  app.add_option("--robot-id", robot_id, "overrides robot_id");
  CLI11_PARSE(app, argc, argv);
  return keyfleet::run_reporting_errors("robot_agent", [&] { return run(options, robot_id); });
}
