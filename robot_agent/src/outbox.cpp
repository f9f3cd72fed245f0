#include "keyfleet/agent/outbox.hpp"

#include <cstring>
#include <limits>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/text_region_blob.hpp"

namespace keyfleet::agent {
namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS pending (
  sequence_number INTEGER PRIMARY KEY,
  created_ns INTEGER NOT NULL,
  last_sent_ns INTEGER,
  sends INTEGER NOT NULL DEFAULT 0,
  frame_index INTEGER NOT NULL,
  capture_time_ns INTEGER NOT NULL,
  vslam_keyframe_index INTEGER NOT NULL,
  window_first_frame INTEGER NOT NULL,
  window_last_frame INTEGER NOT NULL,
  quality_score REAL NOT NULL,
  sharpness_score REAL NOT NULL,
  semantic_score REAL NOT NULL,
  encoding TEXT NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  image BLOB NOT NULL,
  pose BLOB,
  text_regions BLOB
);)sql";

std::vector<std::uint8_t> pose_blob(const Pose& p) {
  const double values[7] = {p.tx, p.ty, p.tz, p.qx, p.qy, p.qz, p.qw};
  std::vector<std::uint8_t> blob(sizeof(values));
  std::memcpy(blob.data(), values, sizeof(values));
  return blob;
}

std::optional<Pose> pose_from_blob(const std::vector<std::uint8_t>& blob) {
  double v[7];
  if (blob.size() != sizeof(v)) return std::nullopt;
  std::memcpy(v, blob.data(), sizeof(v));
  return Pose{v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
}

std::int64_t as_int(std::uint64_t v) { return static_cast<std::int64_t>(v); }

}  // namespace

Outbox::Outbox(const std::string& path, const std::string& robot_id, const OutboxConfig& bounds)
    : db_(path), bounds_(bounds), robot_id_(robot_id) {
  db_.exec(kSchema);
  db_.add_column_if_missing("pending", "text_regions", "BLOB");  // outboxes before the hints
  // FULL, not NORMAL: with NORMAL a power cut can roll back the last transactions, and with them
  // sequence numbers the station already holds; new keyframes would then reuse them.
  db_.exec("PRAGMA synchronous=FULL");
  auto owner = db_.prepare("SELECT value FROM meta WHERE key='robot_id'");
  if (owner.step()) {
    if (owner.text(0) != robot_id)
      throw StartupError("outbox " + path + " belongs to robot '" + owner.text(0) + "', not '" +
                         robot_id + "': use another outbox.path or run directory");
  } else {
    db_.prepare("INSERT INTO meta(key, value) VALUES('robot_id', ?)").bind(1, robot_id).step();
  }
  auto next = db_.prepare("SELECT value FROM meta WHERE key='next_sequence'");
  if (next.step()) next_sequence_ = std::stoull(next.text(0));
}

void Outbox::add(const Keyframe& k, std::int64_t now_ns) {
  if (k.sequence_number != next_sequence_)
    throw std::logic_error("outbox: sequence " + std::to_string(k.sequence_number) +
                           " out of order, expected " + std::to_string(next_sequence_));
  db_.exec("BEGIN");
  try {
    auto insert = db_.prepare(
        "INSERT INTO pending(sequence_number, created_ns, frame_index, capture_time_ns, "
        "vslam_keyframe_index, window_first_frame, window_last_frame, quality_score, "
        "sharpness_score, semantic_score, encoding, width, height, image, pose, text_regions) "
        "VALUES(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    insert.bind(1, as_int(k.sequence_number))
        .bind(2, now_ns)
        .bind(3, as_int(k.frame_index))
        .bind(4, k.capture_time_ns)
        .bind(5, as_int(k.vslam_keyframe_index))
        .bind(6, as_int(k.window_first_frame))
        .bind(7, as_int(k.window_last_frame))
        .bind(8, k.quality_score)
        .bind(9, k.sharpness_score)
        .bind(10, k.semantic_score)
        .bind(11, k.encoding)
        .bind(12, std::int64_t{k.width})
        .bind(13, std::int64_t{k.height})
        .bind(14, k.image);
    if (k.camera_pose)
      insert.bind(15, pose_blob(*k.camera_pose));
    else
      insert.bind_null(15);
    if (k.text_regions.empty())
      insert.bind_null(16);
    else
      insert.bind(16, text_regions_blob(k.text_regions));
    insert.step();
    db_.prepare("INSERT OR REPLACE INTO meta(key, value) VALUES('next_sequence', ?)")
        .bind(1, std::to_string(k.sequence_number + 1))
        .step();
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
  next_sequence_ = k.sequence_number + 1;
}

void Outbox::mark_sent(std::uint64_t sequence, std::int64_t now_ns) {
  db_.prepare("UPDATE pending SET last_sent_ns=?, sends=sends+1 WHERE sequence_number=?")
      .bind(1, now_ns)
      .bind(2, as_int(sequence))
      .step();
}

bool Outbox::acknowledge(std::uint64_t sequence) {
  db_.prepare("DELETE FROM pending WHERE sequence_number=?").bind(1, as_int(sequence)).step();
  return db_.changes() > 0;
}

std::optional<std::uint64_t> Outbox::renumber(std::uint64_t sequence) {
  const std::uint64_t renumbered = next_sequence_;
  db_.exec("BEGIN");
  try {
    db_.prepare(
           "UPDATE pending SET sequence_number=?, last_sent_ns=NULL, sends=0 "
           "WHERE sequence_number=?")
        .bind(1, as_int(renumbered))
        .bind(2, as_int(sequence))
        .step();
    if (db_.changes() == 0) {
      db_.exec("ROLLBACK");
      return std::nullopt;
    }
    db_.prepare("INSERT OR REPLACE INTO meta(key, value) VALUES('next_sequence', ?)")
        .bind(1, std::to_string(renumbered + 1))
        .step();
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
  next_sequence_ = renumbered + 1;
  return renumbered;
}

std::vector<Keyframe> Outbox::due_for_resend(std::int64_t now_ns, std::size_t max) {
  const auto threshold = now_ns - static_cast<std::int64_t>(bounds_.resend_after_s * 1e9);
  auto query = db_.prepare(
      "SELECT sequence_number, frame_index, capture_time_ns, vslam_keyframe_index, "
      "window_first_frame, window_last_frame, quality_score, sharpness_score, semantic_score, "
      "encoding, width, height, image, pose, text_regions FROM pending "
      "WHERE last_sent_ns IS NULL OR last_sent_ns <= ? OR last_sent_ns > ? ORDER BY "
      "sequence_number LIMIT ?");
  query.bind(1, threshold).bind(2, now_ns).bind(3, static_cast<std::int64_t>(max));
  std::vector<Keyframe> due;
  while (query.step()) {
    Keyframe k;
    k.robot_id = robot_id_;
    k.sequence_number = static_cast<std::uint64_t>(query.int64(0));
    k.frame_index = static_cast<std::uint64_t>(query.int64(1));
    k.capture_time_ns = query.int64(2);
    k.vslam_keyframe_index = static_cast<std::uint64_t>(query.int64(3));
    k.window_first_frame = static_cast<std::uint64_t>(query.int64(4));
    k.window_last_frame = static_cast<std::uint64_t>(query.int64(5));
    k.quality_score = query.real(6);
    k.sharpness_score = query.real(7);
    k.semantic_score = query.real(8);
    k.encoding = query.text(9);
    k.width = static_cast<std::uint32_t>(query.int64(10));
    k.height = static_cast<std::uint32_t>(query.int64(11));
    k.image = query.blob(12);
    if (!query.is_null(13)) k.camera_pose = pose_from_blob(query.blob(13));
    if (!query.is_null(14)) k.text_regions = text_regions_from_blob(query.blob(14));
    due.push_back(std::move(k));
  }
  return due;
}

std::vector<std::uint64_t> Outbox::evict(std::int64_t now_ns, bool by_age) {
  if (!clock_checked_) {
    // Created before a reboot restarted the clock: aged from now, as after an outage. Once is
    // enough: every time stored after this comes from the same clock.
    db_.prepare("UPDATE pending SET created_ns = ?1 WHERE created_ns > ?1").bind(1, now_ns).step();
    clock_checked_ = true;
  }
  const auto oldest_allowed = by_age ? now_ns - static_cast<std::int64_t>(bounds_.max_age_s * 1e9)
                                     : std::numeric_limits<std::int64_t>::min();
  auto query = db_.prepare(
      "SELECT sequence_number FROM pending WHERE created_ns < ? OR sequence_number NOT IN "
      "(SELECT sequence_number FROM pending ORDER BY sequence_number DESC LIMIT ?)");
  query.bind(1, oldest_allowed).bind(2, static_cast<std::int64_t>(bounds_.max_pending));
  std::vector<std::uint64_t> evicted;
  while (query.step()) evicted.push_back(static_cast<std::uint64_t>(query.int64(0)));
  for (const auto sequence : evicted) acknowledge(sequence);
  return evicted;
}

std::uint64_t Outbox::pending() const {
  auto query = db_.prepare("SELECT COUNT(*) FROM pending");
  query.step();
  return static_cast<std::uint64_t>(query.int64(0));
}

}  // namespace keyfleet::agent
