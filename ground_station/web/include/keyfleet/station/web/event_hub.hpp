#pragma once
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

namespace keyfleet::station::web {

// The latest state for any number of waiting readers (the dashboard's server-sent events): a
// reader that falls behind gets the newest event, never a backlog.
class EventHub {
 public:
  struct Event {
    std::uint64_t id = 0;
    std::string data;
  };

  // Publishes `data` unless it equals the latest event; true when published.
  bool publish(std::string data);
  // The latest event when newer than `after_id`, else waits up to `timeout` for one. nullopt on
  // timeout or once closed.
  std::optional<Event> next(std::uint64_t after_id, std::chrono::milliseconds timeout);
  // The latest event (id 0 before the first).
  Event latest() const;
  // Wakes every reader and refuses to wait from then on (the server is stopping).
  void close();
  bool closed() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  Event latest_;
  bool closed_ = false;
};

}  // namespace keyfleet::station::web
