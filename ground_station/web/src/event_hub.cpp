#include "keyfleet/station/web/event_hub.hpp"

namespace keyfleet::station::web {

bool EventHub::publish(std::string data) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (latest_.id > 0 && latest_.data == data) return false;
    latest_ = Event{latest_.id + 1, std::move(data)};
  }
  changed_.notify_all();
  return true;
}

std::optional<EventHub::Event> EventHub::next(std::uint64_t after_id,
                                              std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return closed_ || latest_.id > after_id; });
  if (closed_ || latest_.id <= after_id) return std::nullopt;
  return latest_;
}

EventHub::Event EventHub::latest() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

void EventHub::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  changed_.notify_all();
}

bool EventHub::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

}  // namespace keyfleet::station::web
