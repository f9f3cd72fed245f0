#pragma once
// A sample into and out of its mission-log record (idl/mission_log.proto) by protobuf
// reflection: each field of the record's list (types.hpp) goes to the message field of the same
// name, so a new field needs only its line in the .proto. Not logged, by design: the image (the
// log keeps its size and hash, set by the mission log), camera_pose and text_regions. Stages go
// to the repeated "stages" messages (stage, cpu_ms_total, calls).
#include <string>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace google::protobuf {
class Message;
}

namespace keyfleet::station {

void to_proto(const Keyframe& keyframe, google::protobuf::Message& message);
void to_proto(const AgentStats& stats, google::protobuf::Message& message);
void from_proto(const google::protobuf::Message& message, Keyframe& keyframe);
void from_proto(const google::protobuf::Message& message, AgentStats& stats);

// The record's scalar and text fields the message type has no field for (empty when none).
std::vector<std::string> fields_missing_from(const google::protobuf::Message& message,
                                             const Keyframe&);
std::vector<std::string> fields_missing_from(const google::protobuf::Message& message,
                                             const AgentStats&);

}  // namespace keyfleet::station
