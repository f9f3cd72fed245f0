#include "keyfleet/station/places/orb_vocabulary.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <utility>

#include "hamming.hpp"
#include "keyfleet/common/error.hpp"
#include "vocabulary_checks.hpp"

namespace keyfleet::station {
namespace {

using Descriptor = OrbVocabulary::Descriptor;
using detail::hamming256;

struct Cluster {
  Descriptor centroid;
  std::vector<std::uint32_t> members;
};

// Majority vote per bit: the Hamming-space mean DBoW2 uses for binary descriptors.
Descriptor majority(const std::vector<Descriptor>& all, const std::vector<std::uint32_t>& members) {
  std::array<std::uint32_t, 256> ones{};
  for (std::uint32_t m : members) {
    const Descriptor& d = all[m];
    for (int byte = 0; byte < 32; ++byte)
      for (int bit = 0; bit < 8; ++bit)
        ones[std::size_t(byte * 8 + bit)] += (d[std::size_t(byte)] >> bit) & 1u;
  }
  Descriptor out{};
  for (int i = 0; i < 256; ++i)
    if (2 * ones[std::size_t(i)] > members.size())
      out[std::size_t(i / 8)] |= std::uint8_t(1u << (i % 8));
  return out;
}

// Uniform integer below `bound` from the engine's raw output, whose sequence the standard fixes
// (std::uniform_int_distribution is library-specific and would change the file between systems).
std::uint64_t draw_below(std::mt19937_64& rng, std::uint64_t bound) { return rng() % bound; }

// k-means++ seeding then Lloyd iterations in Hamming space; empty clusters are dropped, and
// fewer than k clusters come back when the members hold fewer distinct descriptors.
std::vector<Cluster> kmeans(const std::vector<Descriptor>& all,
                            const std::vector<std::uint32_t>& members, int k, int iterations,
                            std::mt19937_64& rng) {
  const std::size_t n = members.size();
  std::vector<Descriptor> centres;
  centres.push_back(all[members[draw_below(rng, n)]]);
  std::vector<std::uint64_t> nearest_sq(n, std::numeric_limits<std::uint64_t>::max());
  while (int(centres.size()) < k) {
    std::uint64_t total = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint64_t d =
          std::uint64_t(hamming256(all[members[i]].data(), centres.back().data()));
      nearest_sq[i] = std::min(nearest_sq[i], d * d);
      total += nearest_sq[i];
    }
    if (total == 0) break;  // every member already equals a centre
    std::uint64_t r = draw_below(rng, total);
    std::size_t pick = 0;
    while (r >= nearest_sq[pick]) r -= nearest_sq[pick++];
    centres.push_back(all[members[pick]]);
  }

  std::vector<std::uint32_t> assignment(n, 0);
  auto assign = [&] {
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t* d = all[members[i]].data();
      std::uint32_t best = 0;
      int best_distance = std::numeric_limits<int>::max();
      for (std::size_t c = 0; c < centres.size(); ++c) {
        const int distance = hamming256(d, centres[c].data());
        if (distance < best_distance) best_distance = distance, best = std::uint32_t(c);
      }
      changed |= assignment[i] != best;
      assignment[i] = best;
    }
    return changed;
  };
  auto group = [&] {
    std::vector<std::vector<std::uint32_t>> groups(centres.size());
    for (std::size_t i = 0; i < n; ++i) groups[assignment[i]].push_back(members[i]);
    return groups;
  };
  assign();
  for (int it = 0; it < iterations; ++it) {
    const auto groups = group();
    for (std::size_t c = 0; c < centres.size(); ++c)
      if (!groups[c].empty()) centres[c] = majority(all, groups[c]);
    if (!assign()) break;
  }
  // Members stay with the centre they are nearest to, so transform routes them the same way.
  std::vector<Cluster> clusters;
  auto groups = group();
  for (std::size_t c = 0; c < centres.size(); ++c)
    if (!groups[c].empty()) clusters.push_back({centres[c], std::move(groups[c])});
  return clusters;
}

}  // namespace

namespace detail {

void check_vocabulary_params(const VocabularyParams& p, const std::string& where) {
  auto fail = [&](const std::string& what) { throw StartupError(where + ": " + what); };
  if (p.branching < 2 || p.branching > 64) fail("branching must be in [2, 64]");
  if (p.depth < 1 || p.depth > 8) fail("depth must be in [1, 8]");
  if (std::pow(double(p.branching), p.depth) > 2e7) fail("branching^depth above 2e7 words");
  if (p.kmeans_iterations < 0 || p.kmeans_iterations > 1000)
    fail("kmeans_iterations must be in [0, 1000]");
}

}  // namespace detail

OrbVocabulary OrbVocabulary::build(const std::vector<cv::Mat>& descriptors_per_image,
                                   const VocabularyParams& params) {
  detail::check_vocabulary_params(params, "vocabulary parameters");
  std::vector<Descriptor> all;
  for (std::size_t i = 0; i < descriptors_per_image.size(); ++i) {
    const cv::Mat& m = descriptors_per_image[i];
    if (m.empty()) continue;
    if (m.type() != CV_8UC1 || m.cols != kDescriptorBytes)
      throw StartupError("vocabulary build: image " + std::to_string(i) +
                         " has descriptors that are not 32-byte CV_8U rows");
    for (int r = 0; r < m.rows; ++r) {
      Descriptor d;
      std::memcpy(d.data(), m.ptr<std::uint8_t>(r), kDescriptorBytes);
      all.push_back(d);
    }
  }
  if (all.empty()) throw StartupError("vocabulary build: no descriptors in the training images");

  OrbVocabulary vocabulary;
  vocabulary.params_ = params;
  vocabulary.training_images_ = descriptors_per_image.size();
  auto& nodes = vocabulary.nodes_;
  nodes.push_back(Node{});
  std::mt19937_64 rng(params.seed);

  // Breadth first, so that each node's children are contiguous and ids follow levels.
  std::vector<std::vector<std::uint32_t>> pending(1);
  pending[0].resize(all.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) pending[0][i] = i;
  for (NodeId id = 0; id < nodes.size(); ++id) {
    std::vector<std::uint32_t> members = std::move(pending[id]);
    if (int(nodes[id].level) >= params.depth || members.size() <= 1) continue;
    auto clusters = kmeans(all, members, params.branching, params.kmeans_iterations, rng);
    if (clusters.size() <= 1) continue;  // identical descriptors: nothing to split
    nodes[id].first_child = NodeId(nodes.size());
    nodes[id].child_count = std::uint32_t(clusters.size());
    for (auto& c : clusters) {
      Node child;
      child.centroid = c.centroid;
      child.parent = id;
      child.level = nodes[id].level + 1;
      nodes.push_back(child);
      pending.push_back(std::move(c.members));
    }
  }
  vocabulary.index_words();

  // IDF: in how many training images each word appears.
  std::vector<std::uint32_t> images_with(vocabulary.words_.size(), 0);
  std::vector<WordId> seen;
  for (const cv::Mat& m : descriptors_per_image) {
    seen.clear();
    for (int r = 0; r < m.rows; ++r) seen.push_back(vocabulary.word_of(m.ptr<std::uint8_t>(r)));
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    for (WordId w : seen) ++images_with[w];
  }
  const double n_images = double(descriptors_per_image.size());
  for (WordId w = 0; w < vocabulary.words_.size(); ++w) {
    // A word no training image reaches after the last centroid update counts as seen once.
    const double n = std::max<double>(1.0, images_with[w]);
    nodes[vocabulary.words_[w]].idf = float(std::log(n_images / n));
  }
  return vocabulary;
}

void OrbVocabulary::index_words() {
  words_.clear();
  for (NodeId id = 0; id < nodes_.size(); ++id) {
    if (nodes_[id].child_count != 0) continue;
    nodes_[id].word = WordId(words_.size());
    words_.push_back(id);
  }
}

NodeId OrbVocabulary::descend(const std::uint8_t* descriptor, int direct_level,
                              NodeId* direct_node) const {
  NodeId id = 0;
  bool recorded = false;
  while (nodes_[id].child_count != 0) {
    if (direct_node && int(nodes_[id].level) == direct_level) {
      *direct_node = id;
      recorded = true;
    }
    const Node& n = nodes_[id];
    NodeId best = n.first_child;
    int best_distance = std::numeric_limits<int>::max();
    for (NodeId c = n.first_child; c < n.first_child + n.child_count; ++c) {
      const int distance = hamming256(descriptor, nodes_[c].centroid.data());
      if (distance < best_distance) best_distance = distance, best = c;
    }
    id = best;
  }
  if (direct_node && !recorded) *direct_node = id;
  return id;
}

WordId OrbVocabulary::word_of(const std::uint8_t* descriptor) const {
  return nodes_[descend(descriptor, 0, nullptr)].word;
}

BowVector OrbVocabulary::transform(const cv::Mat& descriptors, FeatureVector* direct,
                                   int direct_level_up) const {
  if (direct) direct->clear();
  BowVector bow;
  if (nodes_.empty() || descriptors.empty() || descriptors.type() != CV_8UC1 ||
      descriptors.cols != kDescriptorBytes)
    return bow;
  const int direct_level = std::max(0, params_.depth - std::max(0, direct_level_up));
  std::vector<WordId> words(std::size_t(descriptors.rows));
  std::vector<std::pair<NodeId, std::uint32_t>> under;
  for (int r = 0; r < descriptors.rows; ++r) {
    NodeId node = 0;
    words[std::size_t(r)] =
        nodes_[descend(descriptors.ptr<std::uint8_t>(r), direct_level, direct ? &node : nullptr)]
            .word;
    if (direct) under.emplace_back(node, std::uint32_t(r));
  }

  std::sort(words.begin(), words.end());
  double total = 0;
  for (std::size_t i = 0; i < words.size();) {
    std::size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const double weight = double(j - i) * nodes_[words_[words[i]]].idf;
    if (weight > 0) {
      bow.push_back({words[i], weight});
      total += weight;
    }
    i = j;
  }
  for (auto& e : bow) e.weight /= total;

  if (direct) {
    std::sort(under.begin(), under.end());
    for (const auto& [node, row] : under) {
      if (direct->empty() || direct->back().node != node) direct->push_back({node, {}});
      direct->back().features.push_back(row);
    }
  }
  return bow;
}

double OrbVocabulary::score(const BowVector& a, const BowVector& b) {
  if (a.empty() || b.empty()) return 0.0;
  double l1 = 0;
  auto i = a.begin(), j = b.begin();
  while (i != a.end() || j != b.end()) {
    if (j == b.end() || (i != a.end() && i->word < j->word)) {
      l1 += std::abs(i++->weight);
    } else if (i == a.end() || j->word < i->word) {
      l1 += std::abs(j++->weight);
    } else {
      l1 += std::abs(i++->weight - j++->weight);
    }
  }
  return 1.0 - 0.5 * l1;
}

}  // namespace keyfleet::station
