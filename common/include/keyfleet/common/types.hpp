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
};

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
