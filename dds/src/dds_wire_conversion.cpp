#include "dds_wire_conversion.hpp"

#include <type_traits>
#include <utility>

namespace keyfleet::dds {

namespace {

// One field each way. The wire types' accessors have the fields' names (idl/keyfleet.idl), so the
// field lists in types.hpp expand into the conversions; nested types convert member by member.
template <class A, class B>
void put(const A& in, B& out) {
  out = in;
}
template <class A, class B, std::enable_if_t<std::is_assignable_v<B&, A&&>, int> = 0>
void take(A&& in, B& out) {
  out = std::forward<A>(in);
}

void put(const std::optional<Pose>& in, wire::Pose& p) {
  const Pose pose = in.value_or(Pose{});
  p.tx(pose.tx), p.ty(pose.ty), p.tz(pose.tz);
  p.qx(pose.qx), p.qy(pose.qy), p.qz(pose.qz), p.qw(pose.qw);
}
void take(const wire::Pose& p, std::optional<Pose>& out) {
  out = Pose{p.tx(), p.ty(), p.tz(), p.qx(), p.qy(), p.qz(), p.qw()};
}

void put(const std::vector<TextRegion>& in, std::vector<wire::TextRegion>& out) {
  out.clear();
  for (const TextRegion& r : in) {
    wire::TextRegion w;
    w.x(r.x), w.y(r.y), w.w(r.w), w.h(r.h);
    out.push_back(w);
  }
}
void take(const std::vector<wire::TextRegion>& in, std::vector<TextRegion>& out) {
  out.reserve(in.size());
  for (const auto& r : in) out.push_back({r.x(), r.y(), r.w(), r.h()});
}

void put(const std::vector<StageTime>& in, std::vector<wire::StageTime>& out) {
  out.clear();
  for (const auto& s : in) {
    wire::StageTime w;
    w.stage(s.stage);
    w.cpu_ms_total(s.cpu_ms_total);
    w.calls(s.calls);
    out.push_back(std::move(w));
  }
}
void take(const std::vector<wire::StageTime>& in, std::vector<StageTime>& out) {
  for (const auto& s : in) out.push_back({s.stage(), s.cpu_ms_total(), s.calls()});
}

}  // namespace

#define KEYFLEET_PUT(name, ...) put(in.name, out.name());
#define KEYFLEET_TAKE(name, ...) take(std::move(in.name()), out.name);

void to_wire(const Keyframe& in, wire::Keyframe& out) {
  KEYFLEET_KEYFRAME_FIELDS(KEYFLEET_PUT)
  out.has_pose(in.camera_pose.has_value());
}

Keyframe from_wire(wire::Keyframe&& in) {
  Keyframe out;
  KEYFLEET_KEYFRAME_FIELDS(KEYFLEET_TAKE)
  if (!in.has_pose()) out.camera_pose.reset();
  return out;
}

void to_wire(const AgentStats& in, wire::AgentStats& out){KEYFLEET_AGENT_STATS_FIELDS(KEYFLEET_PUT)}

AgentStats from_wire(const wire::AgentStats& in) {
  AgentStats out;
  KEYFLEET_AGENT_STATS_FIELDS(KEYFLEET_TAKE)
  return out;
}

#undef KEYFLEET_PUT
#undef KEYFLEET_TAKE

void to_wire(const KeyframeAck& in, wire::KeyframeAck& out) {
  out.robot_id(in.robot_id);
  out.sequence_number(in.sequence_number);
  switch (in.status) {
    case AckStatus::kStored: out.status(wire::ACK_STORED); break;
    case AckStatus::kDuplicate: out.status(wire::ACK_DUPLICATE); break;
    case AckStatus::kRejected: out.status(wire::ACK_REJECTED); break;
    case AckStatus::kConflict: out.status(wire::ACK_CONFLICT); break;
  }
  out.reason(in.reason);
}

KeyframeAck from_wire(const wire::KeyframeAck& in) {
  KeyframeAck out;
  out.robot_id = in.robot_id();
  out.sequence_number = in.sequence_number();
  switch (in.status()) {
    case wire::ACK_STORED: out.status = AckStatus::kStored; break;
    case wire::ACK_DUPLICATE: out.status = AckStatus::kDuplicate; break;
    case wire::ACK_CONFLICT: out.status = AckStatus::kConflict; break;
    default: out.status = AckStatus::kRejected; break;
  }
  out.reason = in.reason();
  return out;
}

}  // namespace keyfleet::dds
