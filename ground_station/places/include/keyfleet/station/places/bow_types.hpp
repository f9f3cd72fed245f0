#pragma once
#include <cstdint>
#include <vector>

namespace keyfleet::station {

using WordId = std::uint32_t;
using NodeId = std::uint32_t;

struct BowEntry {
  WordId word = 0;
  double weight = 0.0;
};

// TF-IDF weights sorted by word id, each word once, weights summing to 1 (empty when the
// image had no descriptors or only words present in every training image).
using BowVector = std::vector<BowEntry>;

struct FeatureNode {
  NodeId node = 0;
  std::vector<std::uint32_t> features;  // descriptor rows under this node, ascending
};

// The direct index: vocabulary nodes a few levels above the words, sorted by node id, with the
// descriptors that fell under each; matching compares only descriptors under the same node.
using FeatureVector = std::vector<FeatureNode>;

}  // namespace keyfleet::station
