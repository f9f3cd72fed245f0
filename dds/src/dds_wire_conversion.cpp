#include "dds_wire_conversion.hpp"

namespace keyfleet::dds {

void to_wire(const Keyframe& in, wire::Keyframe& out) {
  out.robot_id(in.robot_id);
  out.sequence_number(in.sequence_number);
  out.frame_index(in.frame_index);
  out.capture_time_ns(in.capture_time_ns);
  out.vslam_keyframe_index(in.vslam_keyframe_index);
  out.window_first_frame(in.window_first_frame);
  out.window_last_frame(in.window_last_frame);
  out.quality_score(in.quality_score);
  out.sharpness_score(in.sharpness_score);
  out.semantic_score(in.semantic_score);
  out.encoding(in.encoding);
  out.width(in.width);
  out.height(in.height);
  out.image(in.image);
  out.has_pose(in.camera_pose.has_value());
  const Pose pose = in.camera_pose.value_or(Pose{});
  wire::Pose& p = out.camera_pose();
  p.tx(pose.tx), p.ty(pose.ty), p.tz(pose.tz);
  p.qx(pose.qx), p.qy(pose.qy), p.qz(pose.qz), p.qw(pose.qw);
  out.text_regions().clear();
  for (const TextRegion& r : in.text_regions) {
    wire::TextRegion w;
    w.x(r.x), w.y(r.y), w.w(r.w), w.h(r.h);
    out.text_regions().push_back(w);
  }
}

Keyframe from_wire(wire::Keyframe&& in) {
  Keyframe out;
  out.robot_id = std::move(in.robot_id());
  out.sequence_number = in.sequence_number();
  out.frame_index = in.frame_index();
  out.capture_time_ns = in.capture_time_ns();
  out.vslam_keyframe_index = in.vslam_keyframe_index();
  out.window_first_frame = in.window_first_frame();
  out.window_last_frame = in.window_last_frame();
  out.quality_score = in.quality_score();
  out.sharpness_score = in.sharpness_score();
  out.semantic_score = in.semantic_score();
  out.encoding = std::move(in.encoding());
  out.width = in.width();
  out.height = in.height();
  out.image = std::move(in.image());
  if (in.has_pose()) {
    const wire::Pose& p = in.camera_pose();
    out.camera_pose = Pose{p.tx(), p.ty(), p.tz(), p.qx(), p.qy(), p.qz(), p.qw()};
  }
  out.text_regions.reserve(in.text_regions().size());
  for (const auto& r : in.text_regions()) out.text_regions.push_back({r.x(), r.y(), r.w(), r.h()});
  return out;
}

void to_wire(const AgentStats& in, wire::AgentStats& out) {
  out.robot_id(in.robot_id);
  out.report_time_ns(in.report_time_ns);
  out.finished(in.finished);
  out.frames_seen(in.frames_seen);
  out.vslam_keyframes(in.vslam_keyframes);
  out.keyframes_sent(in.keyframes_sent);
  out.keyframes_resent(in.keyframes_resent);
  out.keyframes_dropped(in.keyframes_dropped);
  out.keyframes_pending(in.keyframes_pending);
  out.bytes_sent(in.bytes_sent);
  out.bytes_resent(in.bytes_resent);
  out.stream_all_bytes(in.stream_all_bytes);
  out.stream_all_estimated(in.stream_all_estimated);
  out.stream_all_sampled_frames(in.stream_all_sampled_frames);
  out.vslam_keyframe_bytes(in.vslam_keyframe_bytes);
  out.vslam_keyframe_estimated(in.vslam_keyframe_estimated);
  out.stages().clear();
  for (const auto& s : in.stages) {
    wire::StageTime w;
    w.stage(s.stage);
    w.cpu_ms_total(s.cpu_ms_total);
    w.calls(s.calls);
    out.stages().push_back(std::move(w));
  }
}

AgentStats from_wire(const wire::AgentStats& in) {
  AgentStats out;
  out.robot_id = in.robot_id();
  out.report_time_ns = in.report_time_ns();
  out.finished = in.finished();
  out.frames_seen = in.frames_seen();
  out.vslam_keyframes = in.vslam_keyframes();
  out.keyframes_sent = in.keyframes_sent();
  out.keyframes_resent = in.keyframes_resent();
  out.keyframes_dropped = in.keyframes_dropped();
  out.keyframes_pending = in.keyframes_pending();
  out.bytes_sent = in.bytes_sent();
  out.bytes_resent = in.bytes_resent();
  out.stream_all_bytes = in.stream_all_bytes();
  out.stream_all_estimated = in.stream_all_estimated();
  out.stream_all_sampled_frames = in.stream_all_sampled_frames();
  out.vslam_keyframe_bytes = in.vslam_keyframe_bytes();
  out.vslam_keyframe_estimated = in.vslam_keyframe_estimated();
  for (const auto& s : in.stages()) out.stages.push_back({s.stage(), s.cpu_ms_total(), s.calls()});
  return out;
}

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
