#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <shared_mutex>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/station/analysis_types.hpp"
#include "keyfleet/station/geometry/match_verifier.hpp"
#include "keyfleet/station/places/bow_database.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"

namespace keyfleet::station {

// Which stored keyframes a query may match (e.g. not its own robot's recent neighbours).
using PlaceFilter = std::function<bool(const KeyframeKey& key, std::int64_t capture_time_ns)>;

struct PlaceOutcome {
  std::optional<PlaceMatch> best;   // the accepted candidate with most inliers
  std::vector<PlaceMatch> checked;  // every candidate verified, best bag-of-words score first
};

// The seam where place recognition sits. Thread-safe: queries run in parallel, adds are
// exclusive.
class PlaceRecognizer {
 public:
  virtual ~PlaceRecognizer() = default;
  virtual PlaceOutcome recognise(const OrbFeatures& features, const PlaceFilter& filter) const = 0;
  virtual void add(const KeyframeKey& key, std::int64_t capture_time_ns,
                   const OrbFeatures& features) = 0;
  virtual std::size_t size() const = 0;
};

// Excludes the query's own robot within `exclusion_s` of its capture time: those frames see
// the same place because they are consecutive, not because the robot came back.
PlaceFilter not_a_recent_neighbour(const KeyframeKey& query, std::int64_t capture_time_ns,
                                   double exclusion_s);

// ORB bag of words (inverted index) for candidates, the direct index for matching, and a
// geometric verifier (VFC or RANSAC) to accept them: the top `candidates` are verified and the
// one with most inliers is kept when it has more than min_inliers at min_inlier_ratio (Ma and
// Zhao, IEEE Access 2017).
class OrbBowPlaceRecognizer final : public PlaceRecognizer {
 public:
  OrbBowPlaceRecognizer(std::shared_ptr<const OrbVocabulary> vocabulary,
                        std::unique_ptr<MatchVerifier> verifier,
                        const PlaceRecognitionConfig& config);

  PlaceOutcome recognise(const OrbFeatures& features, const PlaceFilter& filter) const override;
  void add(const KeyframeKey& key, std::int64_t capture_time_ns,
           const OrbFeatures& features) override;
  std::size_t size() const override;

 private:
  struct Entry {
    KeyframeKey key;
    std::int64_t capture_time_ns = 0;
    OrbFeatures features;
  };
  PlaceMatch verify(const OrbFeatures& query, const FeatureVector& query_direct,
                    std::uint32_t entry, double bow_score) const;

  std::shared_ptr<const OrbVocabulary> vocabulary_;
  std::unique_ptr<MatchVerifier> verifier_;
  PlaceRecognitionConfig config_;
  mutable std::shared_mutex mutex_;
  BowDatabase database_;
  std::vector<Entry> entries_;  // indexed by the database's entry id
};

}  // namespace keyfleet::station
