#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::station {

// kDuplicate: the same (robot, sequence) with the same image was stored before; kConflict: with
// another image, which is then kept in the conflicts table.
enum class StoreOutcome { kStored, kDuplicate, kConflict };

struct RobotTotals {
  std::string robot_id;
  std::uint64_t keyframes = 0;
  std::uint64_t image_bytes = 0;
  std::uint64_t serialized_bytes = 0;  // as received on the wire
  std::uint64_t rejected = 0;
  std::uint64_t conflicts = 0;  // keyframes whose sequence number was taken by another image
  std::int64_t first_received_ns = 0;
  std::int64_t last_received_ns = 0;
  std::optional<AgentStats> latest_stats;  // the robot's own account, when received
};

struct StoredKeyframeInfo {
  std::string robot_id;
  std::uint64_t sequence = 0;
  std::int64_t capture_time_ns = 0;
  std::optional<Pose> pose;
  std::uint64_t frame_index = 0;  // in the robot's camera stream
  std::int64_t received_ns = 0;
  std::uint64_t serialized_bytes = 0;
  std::uint32_t width = 0, height = 0;
};

// One stats sample of a robot, as it arrived: the baselines it had counted by then.
struct StatsSample {
  std::string robot_id;
  std::int64_t report_time_ns = 0;  // the agent's clock
  std::uint64_t frames_seen = 0;
  std::uint64_t stream_all_bytes = 0;
  std::uint64_t vslam_keyframe_bytes = 0;
};

// The station's durable store: one SQLite file (WAL) with every keyframe (JPEG and
// metadata) exactly once per (robot, sequence), rejections, and each robot's latest stats.
class KeyframeStore {
 public:
  // kReadWrite creates or upgrades the schema; kReadOnly (questions to a finished run) changes
  // nothing in the file and throws SqliteError when it cannot be opened.
  explicit KeyframeStore(const std::string& path, SqliteDb::Mode mode = SqliteDb::Mode::kReadWrite);

  StoreOutcome store(const Keyframe& keyframe, std::uint64_t serialized_bytes,
                     std::int64_t received_ns);
  // Records a rejected sample; true when this (robot, sequence) was not recorded before.
  bool record_rejection(const std::string& robot_id, std::uint64_t sequence,
                        const std::string& reason, std::int64_t received_ns);
  void record_stats(const AgentStats& stats);

  std::vector<RobotTotals> totals() const;
  std::uint64_t keyframe_count() const;
  std::vector<StoredKeyframeInfo> keyframe_index() const;  // oldest received first
  // Every stats sample received, per robot in time order; empty for databases written before
  // the history was kept.
  std::vector<StatsSample> stats_history() const;
  std::optional<Keyframe> load(const std::string& robot_id, std::uint64_t sequence) const;
  const std::string& path() const { return db_.path(); }

 private:
  mutable SqliteDb db_;
  // False in a read-only database written, before versions were kept, without these tables.
  bool has_stats_history_ = true;
  bool has_conflicts_ = true;
};

}  // namespace keyfleet::station
