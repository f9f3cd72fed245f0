#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// The agent's durable store of keyframes not yet acknowledged by a station, in SQLite.
// A keyframe enters before its first transmission and leaves when acknowledged or when
// the configured bounds (count, age) evict it. Sequence numbers continue across restarts.
// Times (now_ns) are on a clock that only moves forward, boot_time_ns() in the agent: ages never
// jump with the wall clock. A time stored before a reboot, in that clock's future, counts as now.
class Outbox {
 public:
  // Throws StartupError when the file belongs to another robot or cannot be opened.
  Outbox(const std::string& path, const std::string& robot_id, const OutboxConfig& bounds);

  std::uint64_t next_sequence() const { return next_sequence_; }
  // Stores the keyframe; its sequence_number must be next_sequence(). `value` orders sending
  // (higher first, then older first); a `held` keyframe (thinned by the link's density) goes
  // only when the caller asks for held ones, and is the first the count bound gives up.
  void add(const Keyframe& keyframe, std::int64_t now_ns, double value = 0, bool held = false);
  void mark_sent(std::uint64_t sequence, std::int64_t now_ns);
  // Removes the keyframe; false when it was not pending (a repeated acknowledgement).
  bool acknowledge(std::uint64_t sequence);
  // Gives a pending keyframe the next sequence number (due for sending at once); returns it, or
  // nothing when `sequence` is not pending.
  std::optional<std::uint64_t> renumber(std::uint64_t sequence);
  // Keyframes never sent or last sent at least resend_after_s ago, at most `max`, in sending
  // order: by value, highest first, then oldest first; held ones only `with_held`, after the
  // rest.
  std::vector<Keyframe> due_for_resend(std::int64_t now_ns, std::size_t max,
                                       bool with_held = false);
  // Applies the bounds (the age one only with `by_age`); returns the sequence numbers given up
  // on. The count bound keeps the newest keyframes that are not held, then the newest held.
  std::vector<std::uint64_t> evict(std::int64_t now_ns, bool by_age = true);
  std::uint64_t pending() const;
  // Image bytes of the pending keyframes that are not held: the backlog the link must carry.
  std::uint64_t pending_bytes() const;
  std::uint64_t held() const;  // pending keyframes held back
  const std::string& path() const { return db_.path(); }
  // The newest layout of the file (PRAGMA user_version) this build writes; opening an older
  // outbox migrates it, a newer one is refused.
  static int schema_version();

 private:
  mutable SqliteDb db_;
  // The two queries the agent runs on every service pass, compiled once (compiling them took most
  // of its `service` stage); after db_, so they are finalized before it closes.
  std::optional<SqliteStatement> due_query_, evict_query_;
  OutboxConfig bounds_;
  bool clock_checked_ = false;  // creation times from before a reboot moved to now
  std::string robot_id_;
  std::uint64_t next_sequence_ = 0;
};

}  // namespace keyfleet::agent
