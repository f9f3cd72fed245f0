#pragma once
// The transport seam. Algorithms and apps see only these interfaces and domain types;
// the DDS adapter (dds_transport.hpp) is the one implementation that knows the wire.
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace keyfleet {

struct PublishResult {
  bool ok = false;
  std::uint64_t serialized_bytes = 0;  // bytes of the serialized sample handed to the wire
  std::string error;
};

// Agent side: sends keyframes and stats, receives the station's acknowledgements.
class AgentLink {
 public:
  virtual ~AgentLink() = default;
  virtual PublishResult publish(const Keyframe& keyframe) = 0;
  virtual PublishResult publish(const AgentStats& stats) = 0;
  // Serialized size the keyframe would have on the wire, without sending it.
  virtual std::uint64_t serialized_size(const Keyframe& keyframe) const = 0;
  virtual std::size_t matched_stations() const = 0;
  // Acknowledgements addressed to `robot_id`; waits up to `wait` for the first one.
  virtual std::vector<KeyframeAck> take_acks(const std::string& robot_id,
                                             std::chrono::milliseconds wait) = 0;
  // Waits until every published stats sample is acknowledged by the matched stations.
  virtual bool flush_stats(std::chrono::milliseconds timeout) = 0;
};

struct ReceivedKeyframe {
  Keyframe keyframe;
  std::uint64_t serialized_bytes = 0;
  // The robot the transport knows the writer as (over DDS: the robot of the keyframe topic it
  // wrote on, which DDS-Security permissions bind to the robot's certificate); empty when the
  // transport cannot tell. A keyframe claiming another robot id is refused.
  std::string sender;
};

struct StationInbox {
  std::vector<ReceivedKeyframe> keyframes;
  std::vector<AgentStats> stats;
  bool empty() const { return keyframes.empty() && stats.empty(); }
};

// Station side: receives from any number of agents, sends acknowledgements.
class StationLink {
 public:
  virtual ~StationLink() = default;
  // Takes what has arrived, waiting up to `wait` when nothing has; at most `max_keyframes`.
  virtual StationInbox take(std::chrono::milliseconds wait, std::size_t max_keyframes) = 0;
  virtual PublishResult acknowledge(const KeyframeAck& ack) = 0;
  virtual std::size_t matched_agents() const = 0;
};

}  // namespace keyfleet
