#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "keyfleet/station/places/bow_types.hpp"

namespace keyfleet::station {

struct BowMatch {
  std::uint32_t entry = 0;
  double score = 0.0;
};

// Keyframes' bag-of-words vectors for retrieval: an inverted index (word -> entries holding it,
// with their weights) answers queries touching only the entries that share a word with the
// query; the direct index of each entry is kept for matching its descriptors afterwards.
// Not synchronised: concurrent queries are fine, an add needs the caller's exclusive lock.
class BowDatabase {
 public:
  // Returns the new entry's id (0, 1, 2, ... in order of addition).
  std::uint32_t add(const BowVector& bow, FeatureVector direct);

  // Best first (score desc, then entry asc), at most max_results, only entries `accept` lets
  // through (all when empty) and with a positive score. The score is the vocabulary's L1 score,
  // computed as the sum over shared words of min(v_i, w_i) (equal for L1-normalised vectors).
  std::vector<BowMatch> query(const BowVector& bow, std::size_t max_results,
                              const std::function<bool(std::uint32_t)>& accept = {}) const;

  // Throws std::out_of_range for an unknown entry (a programming error, not bad input).
  const FeatureVector& direct_index(std::uint32_t entry) const;
  std::size_t size() const { return direct_.size(); }

 private:
  struct Posting {
    std::uint32_t entry;
    float weight;
  };
  std::vector<std::vector<Posting>> inverted_;  // by word id
  std::vector<FeatureVector> direct_;
};

}  // namespace keyfleet::station
