#pragma once
#include <cstddef>
#include <string>

namespace keyfleet {

// A string from a sample a process does not trust (a rejected keyframe's robot id or
// encoding) as it may go into logs, the database, the mission log and the JSON reports: its
// first `max_bytes` bytes, printable ASCII kept and every other byte (control characters,
// invalid UTF-8) and the backslash written as \xNN.
std::string printable_text(const std::string& raw, std::size_t max_bytes = 64);

}  // namespace keyfleet
