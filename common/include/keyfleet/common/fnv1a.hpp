#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace keyfleet {

// 64-bit FNV-1a: a fast content fingerprint for integrity checks and logs, not for security.
inline std::uint64_t fnv1a64(const std::uint8_t* data, std::size_t size) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= data[i];
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

inline std::uint64_t fnv1a64(const std::vector<std::uint8_t>& bytes) {
  return fnv1a64(bytes.data(), bytes.size());
}

}  // namespace keyfleet
