#pragma once
// Plain domain types shared by agent and station. No transport or codec types here.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet {

struct Pose {
  double tx = 0, ty = 0, tz = 0;
  double qx = 0, qy = 0, qz = 0, qw = 1;
};

// A region where the robot's text segmenter saw text, in the sent image's pixels: a hint for
// the station's reader, which checks it (a hint may lie) and may ignore it.
struct TextRegion {
  std::uint16_t x = 0, y = 0, w = 0, h = 0;
  bool operator==(const TextRegion& o) const {
    return x == o.x && y == o.y && w == o.w && h == o.h;
  }
};

struct Keyframe {
  std::string robot_id;
  std::uint64_t sequence_number = 0;
  std::uint64_t frame_index = 0;
  std::int64_t capture_time_ns = 0;
  std::uint64_t vslam_keyframe_index = 0;
  std::uint64_t window_first_frame = 0;
  std::uint64_t window_last_frame = 0;
  double quality_score = 0;
  double sharpness_score = 0;
  double semantic_score = 0;
  std::string encoding = "jpeg";
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::uint8_t> image;
  std::optional<Pose> camera_pose;
  std::vector<TextRegion> text_regions;  // largest first; empty when the robot has none
};

// Keyframe's fields, once, in wire order: F(member, outbox, station), where outbox and station
// are the schema versions of the agent's outbox and of the station's database whose migration
// added the field's column (1: the first layout; 0: that file does not keep it). The wire
// conversion, both stores, the mission log and the exports expand this list (record_fields.hpp):
// a new field is its member above, its line here, and its line in idl/keyfleet.idl and
// idl/mission_log.proto.
#define KEYFLEET_KEYFRAME_FIELDS(F) \
  F(robot_id, 0, 1)                 \
  F(sequence_number, 1, 1)          \
  F(frame_index, 1, 1)              \
  F(capture_time_ns, 1, 1)          \
  F(vslam_keyframe_index, 1, 1)     \
  F(window_first_frame, 1, 1)       \
  F(window_last_frame, 1, 1)        \
  F(quality_score, 1, 1)            \
  F(sharpness_score, 1, 1)          \
  F(semantic_score, 1, 1)           \
  F(encoding, 1, 1)                 \
  F(width, 1, 1)                    \
  F(height, 1, 1)                   \
  F(image, 1, 1)                    \
  F(camera_pose, 1, 1)              \
  F(text_regions, 2, 4)

struct StageTime {
  std::string stage;
  double cpu_ms_total = 0;
  std::uint64_t calls = 0;
};

struct AgentStats {
  std::string robot_id;
  std::int64_t report_time_ns = 0;
  bool finished = false;
  std::uint64_t frames_seen = 0;
  std::uint64_t vslam_keyframes = 0;
  std::uint64_t keyframes_sent = 0;
  std::uint64_t keyframes_resent = 0;
  std::uint64_t keyframes_dropped = 0;
  std::uint64_t keyframes_pending = 0;
  std::uint64_t bytes_sent = 0;
  std::uint64_t bytes_resent = 0;
  std::uint64_t stream_all_bytes = 0;
  bool stream_all_estimated = true;
  std::uint64_t stream_all_sampled_frames = 0;
  std::uint64_t vslam_keyframe_bytes = 0;
  bool vslam_keyframe_estimated = true;
  std::vector<StageTime> stages;
  // Link-aware sending (agent link_adaptation): keyframes sent below the richest level, and
  // selections held back in the outbox by density; the level now, its changes so far, and what
  // the agent estimates of its link (0 while not known).
  std::uint64_t keyframes_reduced = 0;
  std::uint64_t keyframes_thinned = 0;
  std::uint64_t level_changes = 0;
  std::uint32_t send_quality = 0;  // JPEG quality of new keyframes
  double send_scale = 1.0;         // of the camera frame's width and height
  std::uint32_t send_density = 1;  // one selection in send_density goes at once
  double link_bytes_per_s = 0;     // acknowledged sample bytes per busy second
  double link_rtt_ms = 0;          // hand-over to acknowledgement, smoothed
  double backlog_s = 0;  // unacknowledged bytes over link_bytes_per_s; -1: none delivered lately
};

// AgentStats' fields, once, in wire order: F(member, station), station being the schema version
// of the station's database whose migration added the field's column (1: the first layout). As
// for keyframes, a new counter is its member above, its line here, and its line in
// idl/keyfleet.idl and idl/mission_log.proto.
#define KEYFLEET_AGENT_STATS_FIELDS(F) \
  F(robot_id, 1)                       \
  F(report_time_ns, 1)                 \
  F(finished, 1)                       \
  F(frames_seen, 1)                    \
  F(vslam_keyframes, 1)                \
  F(keyframes_sent, 1)                 \
  F(keyframes_resent, 1)               \
  F(keyframes_dropped, 1)              \
  F(keyframes_pending, 1)              \
  F(bytes_sent, 1)                     \
  F(bytes_resent, 1)                   \
  F(stream_all_bytes, 1)               \
  F(stream_all_estimated, 1)           \
  F(stream_all_sampled_frames, 1)      \
  F(vslam_keyframe_bytes, 1)           \
  F(vslam_keyframe_estimated, 1)       \
  F(stages, 1)                         \
  F(keyframes_reduced, 8)              \
  F(keyframes_thinned, 8)              \
  F(level_changes, 8)                  \
  F(send_quality, 8)                   \
  F(send_scale, 8)                     \
  F(send_density, 8)                   \
  F(link_bytes_per_s, 8)               \
  F(link_rtt_ms, 8)                    \
  F(backlog_s, 8)

// kConflict: the station already holds this (robot, sequence) with another image (the robot lost
// its sequence numbers); the station keeps both, and the robot sends its copy again under a new
// number.
enum class AckStatus { kStored, kDuplicate, kRejected, kConflict };

struct KeyframeAck {
  std::string robot_id;
  std::uint64_t sequence_number = 0;
  AckStatus status = AckStatus::kStored;
  std::string reason;
};

const char* to_string(AckStatus status);

}  // namespace keyfleet
