#include "keyfleet/common/shutdown_signal.hpp"

#include <pthread.h>

#include <csignal>

namespace keyfleet {
namespace {

sigset_t termination_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

}  // namespace

void block_termination_signals() {
  const sigset_t set = termination_signals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

ShutdownSignal::ShutdownSignal() {
  waiter_ = std::thread([this] {
    const sigset_t set = termination_signals();
    int signal_number = 0;
    while (sigwait(&set, &signal_number) == 0) {
      if (signal_number == SIGTERM && quitting_.load()) return;  // our own wake-up
      received_ = signal_number;
      stop.request();
    }
  });
}

ShutdownSignal::~ShutdownSignal() {
  quitting_ = true;
  stop.request();
  pthread_kill(waiter_.native_handle(), SIGTERM);
  waiter_.join();
}

void StopToken::request() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requested_ = true;
  }
  changed_.notify_all();
}

bool StopToken::requested() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return requested_;
}

bool StopToken::wait_for(std::chrono::nanoseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout, [this] { return requested_; });
}

}  // namespace keyfleet
