#pragma once
// Where a place query's candidates come from, one object per `places.retrieval` mode. The
// recogniser ranks stored keyframes by the bag of words and/or the holistic descriptor as the
// mode asks and lets the mode combine the two lists; everything else (the station's set-up,
// `keyfleet locate`, the evaluations) asks the mode what it needs instead of naming modes.
// A new mode: its enum value and name (common config), a class and a line in
// retrieval_modes.cpp.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "keyfleet/station/places/place_recognition_config.hpp"

namespace keyfleet::station {

class RetrievalMode {
 public:
  virtual ~RetrievalMode() = default;
  // Ranks stored keyframes by the ORB bag of words.
  virtual bool ranks_by_bow() const = 0;
  // Ranks by the holistic descriptor, so the station runs the descriptor model.
  virtual bool ranks_by_descriptor() const = 0;
  // How far down each list the recogniser reads for `max_results` candidates.
  virtual std::size_t depth(std::size_t max_results, const PlaceRecognitionConfig&) const {
    return max_results;
  }
  // The candidates, best first, from the lists the mode asked for (the others are empty).
  virtual std::vector<std::uint32_t> combine(
      const std::vector<std::uint32_t>& by_bow,
      const std::vector<std::uint32_t>& by_descriptor) const = 0;
};

// The mode object of a configured retrieval; every PlaceRetrieval value has one.
const RetrievalMode& retrieval_mode(PlaceRetrieval retrieval);

// Reciprocal-rank fusion of two ranked lists of entries: score(e) = sum over the lists holding
// e of 1 / (kFusionRankOffset + rank), rank counted from 1; best first, ties to the lower entry.
inline constexpr double kFusionRankOffset = 2.0;
std::vector<std::uint32_t> fuse_ranks(const std::vector<std::uint32_t>& first,
                                      const std::vector<std::uint32_t>& second);

}  // namespace keyfleet::station
