#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace keyfleet {

// Writes `contents` to `path` whole, or throws std::runtime_error naming the path and the
// system's reason (a full disk among them). The bytes go to `path`.tmp first, are flushed to
// the disk and renamed over `path`, so a reader never sees half a file and an old complete file
// is only replaced by a new complete one.
void write_file(const std::filesystem::path& path, std::string_view contents);

// Disk space held in a file of its own, so that the last writes of a run (its reports) still
// succeed after the disk filled up: the process takes the space at start and gives it back
// just before writing them. Holding is best effort: on a disk that is already full the reserve
// is smaller (held_bytes() says how much) and the process goes on.
class DiskReserve {
 public:
  DiskReserve(std::filesystem::path path, std::uint64_t bytes);
  ~DiskReserve();
  DiskReserve(const DiskReserve&) = delete;
  DiskReserve& operator=(const DiskReserve&) = delete;

  std::uint64_t held_bytes() const { return held_; }
  const std::string& problem() const { return problem_; }  // why less than asked was held
  void release();

 private:
  std::filesystem::path path_;
  std::uint64_t held_ = 0;
  std::string problem_;
};

}  // namespace keyfleet
