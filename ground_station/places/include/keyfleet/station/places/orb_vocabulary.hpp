#pragma once
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "keyfleet/station/places/bow_types.hpp"

namespace keyfleet::station {

struct VocabularyParams {
  int branching = 10;          // k: children per node
  int depth = 4;               // L: levels below the root; at most k^L words
  int kmeans_iterations = 10;  // per node, after k-means++ seeding (stops early when stable)
  std::uint32_t seed = 1;
};

// A DBoW2-style vocabulary tree over 256-bit ORB descriptors: hierarchical k-means++ with
// Hamming distance and majority-bit centroids, IDF weights log(N / n_i) on the leaves (words).
// Same descriptors, parameters and seed give the same tree and a byte-identical file.
// Immutable once built or loaded: const methods may run on several threads at once.
class OrbVocabulary {
 public:
  static constexpr int kDescriptorBytes = 32;
  using Descriptor = std::array<std::uint8_t, kDescriptorBytes>;

  struct Node {
    Descriptor centroid{};
    NodeId parent = 0;       // the root is its own parent
    NodeId first_child = 0;  // children are contiguous
    std::uint32_t child_count = 0;
    std::uint32_t level = 0;  // root 0
    WordId word = 0;          // valid for leaves
    float idf = 0.0f;         // leaves only
  };

  OrbVocabulary() = default;

  // One CV_8U N x 32 matrix per training image (empty ones count as images without words).
  // Throws StartupError on bad parameters or descriptors of another type or width.
  static OrbVocabulary build(const std::vector<cv::Mat>& descriptors_per_image,
                             const VocabularyParams& params);

  // Versioned little-endian binary file with a checksum; errors throw StartupError naming
  // the file and what is wrong (cannot open, bad magic, version, truncated, checksum, tree).
  void save(const std::string& path) const;
  static OrbVocabulary load(const std::string& path);

  // Words of each descriptor row, TF-IDF weighted and L1-normalised. With `direct`, also fills
  // the direct index at level depth - direct_level_up (or the word itself when shallower).
  // Rows that are not 32-byte CV_8U descriptors give an empty vector: never throws.
  BowVector transform(const cv::Mat& descriptors, FeatureVector* direct = nullptr,
                      int direct_level_up = 2) const;

  // 1 - 0.5 * |v - w|_1 for L1-normalised vectors: 1 when identical, 0 when disjoint or empty.
  static double score(const BowVector& a, const BowVector& b);

  bool empty() const { return nodes_.empty(); }
  const VocabularyParams& params() const { return params_; }
  std::size_t word_count() const { return words_.size(); }
  std::size_t node_count() const { return nodes_.size(); }
  std::uint64_t training_images() const { return training_images_; }
  const std::vector<Node>& nodes() const { return nodes_; }

  // The leaf a descriptor falls into, following the nearest centroid level by level.
  WordId word_of(const std::uint8_t* descriptor) const;

 private:
  NodeId descend(const std::uint8_t* descriptor, int direct_level, NodeId* direct_node) const;
  void index_words();

  VocabularyParams params_;
  std::vector<Node> nodes_;    // breadth-first: node 0 is the root
  std::vector<NodeId> words_;  // word id -> leaf node
  std::uint64_t training_images_ = 0;
};

}  // namespace keyfleet::station
