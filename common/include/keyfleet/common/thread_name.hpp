#pragma once
#include <string>

namespace keyfleet {

// Names the calling thread ("kf-" + `role`, cut to the 15 characters Linux keeps) so that
// `top -H`, `ps -L`, perf and gdb tell the process's threads apart; a failure changes nothing
// else. Each thread a keyfleet library starts calls it first.
void name_this_thread(const std::string& role);

// The calling thread's name as the kernel holds it ("" where it cannot be read).
std::string this_thread_name();

}  // namespace keyfleet
