#include "keyfleet/station/mission_log.hpp"

#include <google/protobuf/io/zero_copy_stream_impl.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/util/delimited_message_util.h>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/fnv1a.hpp"
#include "mission_log.pb.h"

namespace keyfleet::station {

MissionLog::MissionLog(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw StartupError("cannot open mission log " + path +
                       " for appending: " + std::strerror(errno));
  size_ = ::lseek(fd_, 0, SEEK_END);
}

MissionLog::~MissionLog() {
  if (fd_ >= 0) ::close(fd_);
}

template <class Record>
void MissionLog::append(const Record& record) {
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::util::SerializeDelimitedToZeroCopyStream(record, &stream);
  }
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      if (written > 0 && ::ftruncate(fd_, size_) != 0) {
        throw std::runtime_error("mission log " + path_ + ": a record was cut short (" +
                                 std::strerror(error) +
                                 ") and could not be removed: " + std::strerror(errno));
      }
      throw std::runtime_error("cannot append to mission log " + path_ + ": " +
                               std::strerror(error));
    }
    written += static_cast<std::size_t>(n);
  }
  size_ += static_cast<std::int64_t>(bytes.size());
}

void MissionLog::keyframe(const Keyframe& k, std::uint64_t serialized_bytes,
                          std::int64_t received_ns) {
  records::MissionLogRecord record;
  auto* r = record.mutable_keyframe();
  r->set_robot_id(k.robot_id);
  r->set_sequence_number(k.sequence_number);
  r->set_frame_index(k.frame_index);
  r->set_capture_time_ns(k.capture_time_ns);
  r->set_received_time_ns(received_ns);
  r->set_vslam_keyframe_index(k.vslam_keyframe_index);
  r->set_window_first_frame(k.window_first_frame);
  r->set_window_last_frame(k.window_last_frame);
  r->set_quality_score(k.quality_score);
  r->set_sharpness_score(k.sharpness_score);
  r->set_semantic_score(k.semantic_score);
  r->set_encoding(k.encoding);
  r->set_width(k.width);
  r->set_height(k.height);
  r->set_image_bytes(k.image.size());
  r->set_image_fnv1a64(fnv1a64(k.image));
  r->set_serialized_bytes(serialized_bytes);
  append(record);
}

void MissionLog::rejected(const std::string& robot_id, std::uint64_t sequence,
                          const std::string& reason, std::int64_t received_ns) {
  records::MissionLogRecord record;
  auto* r = record.mutable_rejected();
  r->set_robot_id(robot_id);
  r->set_sequence_number(sequence);
  r->set_received_time_ns(received_ns);
  r->set_reason(reason);
  append(record);
}

void MissionLog::agent_stats(const AgentStats& s) {
  records::MissionLogRecord record;
  auto* r = record.mutable_agent_stats();
  r->set_robot_id(s.robot_id);
  r->set_report_time_ns(s.report_time_ns);
  r->set_finished(s.finished);
  r->set_frames_seen(s.frames_seen);
  r->set_vslam_keyframes(s.vslam_keyframes);
  r->set_keyframes_sent(s.keyframes_sent);
  r->set_keyframes_resent(s.keyframes_resent);
  r->set_keyframes_dropped(s.keyframes_dropped);
  r->set_keyframes_pending(s.keyframes_pending);
  r->set_bytes_sent(s.bytes_sent);
  r->set_bytes_resent(s.bytes_resent);
  r->set_stream_all_bytes(s.stream_all_bytes);
  r->set_stream_all_estimated(s.stream_all_estimated);
  r->set_stream_all_sampled_frames(s.stream_all_sampled_frames);
  r->set_vslam_keyframe_bytes(s.vslam_keyframe_bytes);
  r->set_vslam_keyframe_estimated(s.vslam_keyframe_estimated);
  for (const auto& stage : s.stages) {
    auto* t = r->add_stages();
    t->set_stage(stage.stage);
    t->set_cpu_ms_total(stage.cpu_ms_total);
    t->set_calls(stage.calls);
  }
  append(record);
}

void MissionLog::event(const std::string& what, std::int64_t time_ns) {
  records::MissionLogRecord record;
  record.mutable_event()->set_what(what);
  record.mutable_event()->set_time_ns(time_ns);
  append(record);
}

std::size_t read_mission_log_kinds(const std::string& path, std::vector<std::string>& kinds) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot open mission log " + path);
  google::protobuf::io::FileInputStream input(fd);
  input.SetCloseOnDelete(true);
  records::MissionLogRecord record;
  bool clean_eof = false;
  while (google::protobuf::util::ParseDelimitedFromZeroCopyStream(&record, &input, &clean_eof)) {
    switch (record.record_case()) {
      case records::MissionLogRecord::kKeyframe: kinds.emplace_back("keyframe"); break;
      case records::MissionLogRecord::kRejected: kinds.emplace_back("rejected"); break;
      case records::MissionLogRecord::kAgentStats: kinds.emplace_back("agent_stats"); break;
      case records::MissionLogRecord::kEvent: kinds.emplace_back("event"); break;
      default: kinds.emplace_back("unknown"); break;
    }
  }
  if (!clean_eof)
    throw std::runtime_error("mission log " + path + " is corrupt after " +
                             std::to_string(kinds.size()) + " records");
  return kinds.size();
}

}  // namespace keyfleet::station
