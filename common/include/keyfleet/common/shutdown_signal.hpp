#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace keyfleet {

// A stop request that loops can poll or wait on instead of sleeping.
class StopToken {
 public:
  void request();
  bool requested() const;
  // Waits up to `timeout`; true when a stop was requested.
  bool wait_for(std::chrono::nanoseconds timeout) const;

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  bool requested_ = false;
};

// Blocks SIGINT and SIGTERM in the calling thread and every thread it starts later.
// Call first thing in main, before any library starts threads.
void block_termination_signals();

// Turns SIGINT/SIGTERM into a StopToken request, from a dedicated sigwait thread (no work
// in a signal handler). Requires block_termination_signals() to have been called.
class ShutdownSignal {
 public:
  ShutdownSignal();
  ~ShutdownSignal();
  ShutdownSignal(const ShutdownSignal&) = delete;
  ShutdownSignal& operator=(const ShutdownSignal&) = delete;

  StopToken stop;
  int received() const { return received_.load(); }

 private:
  std::atomic<int> received_{0};
  std::atomic<bool> quitting_{false};
  std::thread waiter_;
};

}  // namespace keyfleet
