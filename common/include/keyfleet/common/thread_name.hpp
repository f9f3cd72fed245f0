#pragma once
#include <string>

namespace keyfleet {

// Names the calling thread ("kf-" + `role`, cut to the 15 characters Linux keeps) so that
// `top -H`, `ps -L`, perf and gdb tell the process's threads apart; a failure changes nothing
// else. The long-lived threads keyfleet starts (analysis workers, dashboard, HTTP, signals) call
// it first; pools of short tasks (boost::asio's handlers, the evaluation runner's) do not.
void name_this_thread(const std::string& role);

// The calling thread's name as the kernel holds it ("" where it cannot be read).
std::string this_thread_name();

}  // namespace keyfleet
