#include "keyfleet/common/run_folder_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "keyfleet/common/error.hpp"

namespace keyfleet {

RunFolderLock::RunFolderLock(const std::string& folder, const std::string& name) {
  const std::string path = (std::filesystem::path(folder) / name).string();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd_ < 0)
    throw StartupError("cannot open the run folder's lock " + path + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    char holder[32] = {};
    const ssize_t n = ::pread(fd_, holder, sizeof holder - 1, 0);
    ::close(fd_);
    fd_ = -1;
    throw StartupError("run folder " + folder + " is in use by another process (pid " +
                       (n > 0 ? std::string(holder, static_cast<std::size_t>(n)) : "unknown") +
                       ", holding " + path + "): give each process a run folder of its own");
  }
  // The pid is for the message above only (best effort); the lock is the flock, released
  // when this process exits, however it exits.
  const std::string pid = std::to_string(::getpid());
  const bool noted = ::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, pid.data(), pid.size(), 0) >= 0;
  static_cast<void>(noted);
}

RunFolderLock::~RunFolderLock() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

}  // namespace keyfleet
