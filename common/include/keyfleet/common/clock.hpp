#pragma once
#include <chrono>
#include <cstdint>

namespace keyfleet {

inline std::int64_t wall_time_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// For ages and intervals that must outlive the process: CLOCK_BOOTTIME, which setting the clock
// never moves, which counts time suspended, and which runs on across process restarts (it starts
// again from 0 at a reboot).
std::int64_t boot_time_ns();

// CPU time of the calling thread, for per-stage cost accounting.
double thread_cpu_ms();

// CPU time of the whole process (all its threads) so far, in seconds.
double process_cpu_s();

}  // namespace keyfleet
