#pragma once
#include <cstdint>
#include <cstring>

namespace keyfleet::station::detail {

// Bit count without relying on a popcnt instruction (the default x86-64 target has none);
// compilers turn this into popcnt where the target allows it.
inline int popcount64(std::uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ULL);
  x = (x & 0x3333333333333333ULL) + ((x >> 2) & 0x3333333333333333ULL);
  x = (x + (x >> 4)) & 0x0F0F0F0F0F0F0F0FULL;
  return int((x * 0x0101010101010101ULL) >> 56);
}

// Hamming distance between two 256-bit descriptors (memcpy: rows need not be 8-byte aligned).
inline int hamming256(const std::uint8_t* a, const std::uint8_t* b) {
  int distance = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    distance += popcount64(x ^ y);
  }
  return distance;
}

}  // namespace keyfleet::station::detail
