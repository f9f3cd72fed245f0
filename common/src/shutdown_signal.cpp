#include "keyfleet/common/shutdown_signal.hpp"

#include <pthread.h>

#include <cerrno>
#include <csignal>
#include <ctime>

#include "keyfleet/common/thread_name.hpp"

namespace keyfleet {
namespace {

sigset_t termination_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

// A termination signal that reached a thread which does not block it: one a library started
// before main blocked the signals (OpenBLAS's pthread build starts its pool when it loads). The
// handler only records it; the waiter thread picks it up.
std::atomic<int> caught_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler must not take a lock");

extern "C" void record_termination_signal(int signal_number) { caught_signal.store(signal_number); }

}  // namespace

void block_termination_signals() {
  const sigset_t set = termination_signals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  // Threads that were started before this call still have the signals unblocked; without a
  // handler, a SIGTERM delivered to one of them would end the process before its reports.
  struct sigaction action {};
  action.sa_handler = record_termination_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

ShutdownSignal::ShutdownSignal() {
  waiter_ = std::thread([this] {
    name_this_thread("signals");
    const sigset_t set = termination_signals();
    const timespec poll_period{0, 100'000'000};  // for signals the handler recorded instead
    while (true) {
      int signal_number = sigtimedwait(&set, nullptr, &poll_period);
      if (signal_number < 0) {
        if (errno != EAGAIN && errno != EINTR) return;
        signal_number = caught_signal.exchange(0);
        if (signal_number == 0) {
          if (quitting_.load()) return;
          continue;
        }
      }
      if (quitting_.load()) return;  // our own wake-up, or a signal while leaving
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
