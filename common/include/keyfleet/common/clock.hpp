#pragma once
#include <chrono>
#include <cstdint>

namespace keyfleet {

inline std::int64_t wall_time_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// CPU time of the calling thread, for per-stage cost accounting.
double thread_cpu_ms();

}  // namespace keyfleet
