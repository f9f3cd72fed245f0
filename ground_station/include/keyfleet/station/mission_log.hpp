#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/common/types.hpp"

namespace keyfleet::station {

// Appends length-delimited keyfleet.records.MissionLogRecord messages (mission_log.proto)
// to a file: metadata of every stored or rejected keyframe, agent stats, station events.
// A record is written whole or not at all: a write that fails (a full disk) is cut back off the
// file, which stays readable, and throws std::runtime_error naming the file and the reason.
class MissionLog {
 public:
  explicit MissionLog(const std::string& path);  // throws StartupError when unwritable
  ~MissionLog();
  MissionLog(const MissionLog&) = delete;
  MissionLog& operator=(const MissionLog&) = delete;

  void keyframe(const Keyframe& keyframe, std::uint64_t serialized_bytes, std::int64_t received_ns);
  void rejected(const std::string& robot_id, std::uint64_t sequence, const std::string& reason,
                std::int64_t received_ns);
  void agent_stats(const AgentStats& stats);
  void event(const std::string& what, std::int64_t time_ns);

  const std::string& path() const { return path_; }

 private:
  template <class Record>
  void append(const Record& record);
  std::string path_;
  int fd_ = -1;
  std::int64_t size_ = 0;  // the file's length after the last whole record
};

// Reads a mission log back (for tools and tests): appends each record's kind
// (keyframe, rejected, agent_stats, event). Throws std::runtime_error on a corrupt file.
std::size_t read_mission_log_kinds(const std::string& path, std::vector<std::string>& record_kinds);

}  // namespace keyfleet::station
