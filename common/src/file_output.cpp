#include "keyfleet/common/file_output.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace keyfleet {
namespace {

std::string reason(int error) { return std::strerror(error); }

// Writes every byte or returns the errno that stopped it.
int write_all(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return 0;
}

}  // namespace

void write_file(const std::filesystem::path& path, std::string_view contents) {
  const std::string temporary = path.string() + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write " + path.string() + ": " + reason(errno));
  int error = write_all(fd, contents.data(), contents.size());
  if (error == 0 && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error == 0 && std::rename(temporary.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(temporary.c_str());
    throw std::runtime_error("cannot write " + path.string() + ": " + reason(error));
  }
}

DiskReserve::DiskReserve(std::filesystem::path path, std::uint64_t bytes) : path_(std::move(path)) {
  if (bytes == 0) return;
  const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) {
    problem_ = "cannot create " + path_.string() + ": " + reason(errno);
    return;
  }
  // Written, not only sized: a sparse file would hold nothing.
  const std::vector<char> zeros(std::size_t{1} << 16, 0);
  while (held_ < bytes) {
    const std::size_t chunk =
        static_cast<std::size_t>(std::min<std::uint64_t>(zeros.size(), bytes - held_));
    if (const int error = write_all(fd, zeros.data(), chunk); error != 0) {
      problem_ = "only " + std::to_string(held_) + " of " + std::to_string(bytes) +
                 " bytes held in " + path_.string() + ": " + reason(error);
      break;
    }
    held_ += chunk;
  }
  if (::fsync(fd) != 0 && problem_.empty())
    problem_ = "cannot flush " + path_.string() + ": " + reason(errno);
  ::close(fd);
}

DiskReserve::~DiskReserve() { release(); }

void DiskReserve::release() {
  std::error_code ignored;
  std::filesystem::remove(path_, ignored);
  held_ = 0;
}

}  // namespace keyfleet
