#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace keyfleet::station {

struct DescriptorMatch {
  std::uint32_t entry = 0;
  float similarity = 0;  // cosine similarity (the descriptors are L2-normalised)
};

// Holistic place descriptors for retrieval by exact search: one contiguous row per entry, every
// query a dot product with every row (10k entries of 256 floats = 10 MB read per query).
// Not synchronised: concurrent queries are fine, an add needs the caller's exclusive lock.
class DescriptorIndex {
 public:
  explicit DescriptorIndex(int dimensions);

  // Returns the new entry's id (0, 1, 2, ... in order of addition). Throws
  // std::invalid_argument when the descriptor's length is not dimensions().
  std::uint32_t add(const std::vector<float>& descriptor);

  // The max_results most similar entries `accept` lets through (all when empty), most similar
  // first (ties: lower entry first). Throws std::invalid_argument on a wrong length.
  std::vector<DescriptorMatch> query(const std::vector<float>& descriptor, std::size_t max_results,
                                     const std::function<bool(std::uint32_t)>& accept = {}) const;

  int dimensions() const { return dimensions_; }
  std::size_t size() const { return rows_.size() / static_cast<std::size_t>(dimensions_); }

 private:
  int dimensions_;
  std::vector<float> rows_;
};

}  // namespace keyfleet::station
