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
#include "keyfleet/station/record_proto.hpp"
#include "mission_log.pb.h"

namespace keyfleet::station {

MissionLog::MissionLog(const std::string& path) : path_(path) {
  // A field added to a sample but not to idl/mission_log.proto would be left out of every record.
  records::MissionLogRecord record;
  std::vector<std::string> missing = fields_missing_from(*record.mutable_keyframe(), Keyframe{});
  for (auto& name : fields_missing_from(*record.mutable_agent_stats(), AgentStats{}))
    missing.push_back(name);
  if (!missing.empty())
    throw StartupError("idl/mission_log.proto lacks the sample field " + missing.front());
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
  to_proto(k, *r);
  r->set_received_time_ns(received_ns);
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
  to_proto(s, *record.mutable_agent_stats());
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
