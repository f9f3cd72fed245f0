#include "keyfleet/station/places/retrieval_modes.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

namespace keyfleet::station {
namespace {

// The ORB bag of words over an inverted index (Galvez-Lopez and Tardos).
class BowRetrieval final : public RetrievalMode {
 public:
  bool ranks_by_bow() const override { return true; }
  bool ranks_by_descriptor() const override { return false; }
  std::vector<std::uint32_t> combine(const std::vector<std::uint32_t>& by_bow,
                                     const std::vector<std::uint32_t>&) const override {
    return by_bow;
  }
};

// Exact cosine search over the holistic CNN descriptors.
class CnnRetrieval final : public RetrievalMode {
 public:
  bool ranks_by_bow() const override { return false; }
  bool ranks_by_descriptor() const override { return true; }
  std::vector<std::uint32_t> combine(
      const std::vector<std::uint32_t>&,
      const std::vector<std::uint32_t>& by_descriptor) const override {
    return by_descriptor;
  }
};

// Both lists, read `fusion_depth` deep, fused by reciprocal rank.
class FusionRetrieval final : public RetrievalMode {
 public:
  bool ranks_by_bow() const override { return true; }
  bool ranks_by_descriptor() const override { return true; }
  std::size_t depth(std::size_t max_results, const PlaceRecognitionConfig& config) const override {
    return std::max(max_results, static_cast<std::size_t>(config.fusion_depth));
  }
  std::vector<std::uint32_t> combine(
      const std::vector<std::uint32_t>& by_bow,
      const std::vector<std::uint32_t>& by_descriptor) const override {
    return fuse_ranks(by_bow, by_descriptor);
  }
};

}  // namespace

const RetrievalMode& retrieval_mode(PlaceRetrieval retrieval) {
  // Every mode, once.
  static const BowRetrieval bow;
  static const CnnRetrieval cnn;
  static const FusionRetrieval fusion;
  static const std::map<PlaceRetrieval, const RetrievalMode*> modes = {
      {PlaceRetrieval::kBow, &bow},
      {PlaceRetrieval::kCnn, &cnn},
      {PlaceRetrieval::kFusion, &fusion},
  };
  const auto it = modes.find(retrieval);
  if (it == modes.end())
    throw std::logic_error("place retrieval mode " + std::to_string(static_cast<int>(retrieval)) +
                           " has no RetrievalMode");
  return *it->second;
}

std::vector<std::uint32_t> fuse_ranks(const std::vector<std::uint32_t>& first,
                                      const std::vector<std::uint32_t>& second) {
  std::map<std::uint32_t, double> score;
  for (const auto* list : {&first, &second})
    for (std::size_t r = 0; r < list->size(); ++r)
      score[(*list)[r]] += 1.0 / (kFusionRankOffset + double(r + 1));
  std::vector<std::pair<std::uint32_t, double>> ranked(score.begin(), score.end());
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  std::vector<std::uint32_t> out;
  out.reserve(ranked.size());
  for (const auto& [entry, s] : ranked) out.push_back(entry);
  return out;
}

}  // namespace keyfleet::station
