#pragma once
// The Fast DDS adapter. This header names no Fast DDS type; only dds_*.cpp include them.
#include <memory>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/robot_admission.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/common/transport.hpp"

namespace keyfleet {

// Sends Fast DDS's own log (errors, warnings) to `logger` instead of stdout.
// Process-wide by Fast DDS's design: call once from main.
void route_fastdds_log(Logger logger);

// Applies the environment overrides KEYFLEET_DOMAIN and KEYFLEET_PARTITION; throws
// StartupError when they are malformed.
void apply_dds_environment(DdsSettings& settings);

// Both throw StartupError naming the entity that could not be created.
std::unique_ptr<AgentLink> make_dds_agent_link(const DdsSettings& settings,
                                               const std::string& robot_id, Logger logger);
// The station reads the topics of the robots `admission` admits (null: the default limits'),
// as their writers are discovered. Its take() runs on the caller's thread: no sample is
// converted, validated or decoded on a Fast DDS thread. Each robot's keyframe and stats readers
// keep a few samples (KEEP_LAST, bounded resource limits); one overwritten before it is taken
// is not acknowledged, so the agent's outbox sends it again.
std::unique_ptr<StationLink> make_dds_station_link(
    const DdsSettings& settings, Logger logger,
    std::shared_ptr<RobotAdmission> admission = nullptr);

}  // namespace keyfleet
