#pragma once
// One process per run folder: a second station (or agent) on the same folder would interleave
// its database, reports and outbox with the first's.
#include <string>

namespace keyfleet {

class RunFolderLock {
 public:
  // Takes an exclusive lock (flock) on <folder>/<name> for this object's life and writes this
  // process's id into it; throws StartupError naming the folder and the holder's pid when
  // another process holds it.
  RunFolderLock(const std::string& folder, const std::string& name);
  ~RunFolderLock();
  RunFolderLock(const RunFolderLock&) = delete;
  RunFolderLock& operator=(const RunFolderLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace keyfleet
