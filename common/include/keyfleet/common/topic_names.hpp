#pragma once
// The names on the wire that the transport and the fleet's DDS-Security permissions share.

namespace keyfleet {

// Topic names, shared by every process of a mission (partitions separate missions). Each robot
// writes its keyframes and stats on topics of its own, "<prefix><robot id>", so that access
// control can allow a robot to publish as itself only; the station subscribes to each robot's
// topics as it discovers them. Acknowledgements share one topic, written by the station only.
inline constexpr const char* kKeyframeTopicPrefix = "keyfleet/keyframes/";
inline constexpr const char* kAgentStatsTopicPrefix = "keyfleet/agent_stats/";
inline constexpr const char* kKeyframeAckTopic = "keyfleet/keyframe_acks";
// The DDS-Security identity of the station (robots are known by their robot id).
inline constexpr const char* kStationIdentity = "station";

}  // namespace keyfleet
