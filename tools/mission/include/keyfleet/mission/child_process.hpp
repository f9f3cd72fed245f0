#pragma once
#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace keyfleet::mission {

struct ExitStatus {
  bool exited = false;  // false: killed by a signal
  int code = 0;         // exit code, or the signal number
  double cpu_s = 0;     // user + system CPU seconds the child used, all its threads
  bool ok() const { return exited && code == 0; }
  std::string describe() const;
};

// A child process whose stdout and stderr go to one log file. Not copyable; the
// destructor kills (SIGKILL) and reaps a child that is still running.
class ChildProcess {
 public:
  // Throws std::runtime_error when the program cannot be started.
  ChildProcess(std::string name, const std::vector<std::string>& argv, const std::string& log_path);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  const std::string& name() const { return name_; }
  pid_t pid() const { return pid_; }
  const std::string& log_path() const { return log_path_; }

  // Non-blocking: the exit status once the child has ended.
  std::optional<ExitStatus> poll();
  // Waits up to `timeout` for the child to end.
  std::optional<ExitStatus> wait_for(std::chrono::milliseconds timeout);
  void signal(int signal_number);

 private:
  std::string name_;
  std::string log_path_;
  pid_t pid_ = -1;
  int pidfd_ = -1;
  std::optional<ExitStatus> status_;
};

// The last `lines` lines of a text file (for error messages).
std::string tail_of_file(const std::string& path, std::size_t lines);

}  // namespace keyfleet::mission
