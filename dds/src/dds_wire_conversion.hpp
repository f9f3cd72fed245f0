#pragma once
// Domain <-> generated wire types. Internal to the DDS adapter.
#include "keyfleet.h"
#include "keyfleet/common/types.hpp"

namespace keyfleet::dds {

void to_wire(const Keyframe& in, wire::Keyframe& out);
Keyframe from_wire(wire::Keyframe&& in);
void to_wire(const AgentStats& in, wire::AgentStats& out);
AgentStats from_wire(const wire::AgentStats& in);
void to_wire(const KeyframeAck& in, wire::KeyframeAck& out);
KeyframeAck from_wire(const wire::KeyframeAck& in);

}  // namespace keyfleet::dds
