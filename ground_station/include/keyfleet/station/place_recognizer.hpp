#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <shared_mutex>
#include <vector>

#include "keyfleet/station/analysis_types.hpp"
#include "keyfleet/station/geometry/match_verifier.hpp"
#include "keyfleet/station/places/bow_database.hpp"
#include "keyfleet/station/places/descriptor_index.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"
#include "keyfleet/station/places/retrieval_modes.hpp"

namespace keyfleet::station {

// Which stored keyframes a query may match (e.g. not its own robot's recent neighbours).
using PlaceFilter = std::function<bool(const KeyframeKey& key, std::int64_t capture_time_ns)>;

// What place recognition knows of one view: its ORB features (bag of words, verification) and,
// where a descriptor model runs, its holistic descriptor (L2-normalised; empty otherwise).
struct PlaceView {
  OrbFeatures features;
  std::vector<float> descriptor;
};

struct PlaceOutcome {
  std::optional<PlaceMatch> best;   // the accepted candidate with most inliers
  std::vector<PlaceMatch> checked;  // every candidate verified, best retrieval rank first
};

// The seam where place recognition sits. Thread-safe: queries run in parallel, adds are
// exclusive.
class PlaceRecognizer {
 public:
  virtual ~PlaceRecognizer() = default;
  virtual PlaceOutcome recognise(const PlaceView& view, const PlaceFilter& filter) const = 0;
  // Most similar first, at most max_results: the candidates recognise() would verify, before
  // verification (retrieval evaluations read deeper than the verified few).
  virtual std::vector<KeyframeKey> retrieve(const PlaceView& view, std::size_t max_results,
                                            const PlaceFilter& filter) const = 0;
  virtual void add(const KeyframeKey& key, std::int64_t capture_time_ns, const PlaceView& view) = 0;
  // What the station does with each keyframe: recognise it, then add it. An implementation may
  // share the work of the two (the bag of words is computed once).
  virtual PlaceOutcome recognise_then_add(const KeyframeKey& key, std::int64_t capture_time_ns,
                                          const PlaceView& view, const PlaceFilter& filter) {
    PlaceOutcome outcome = recognise(view, filter);
    add(key, capture_time_ns, view);
    return outcome;
  }
  virtual std::size_t size() const = 0;
};

// Excludes the query's own robot within `exclusion_s` of its capture time: those frames see
// the same place because they are consecutive, not because the robot came back.
PlaceFilter not_a_recent_neighbour(const KeyframeKey& query, std::int64_t capture_time_ns,
                                   double exclusion_s);

// Candidates by retrieval (config.retrieval's RetrievalMode: ORB bag of words over an inverted
// index, exact cosine search over holistic descriptors, or both fused by rank), then the direct
// index for matching and a geometric verifier (VFC or RANSAC) to accept them: the top `candidates`
// are verified and the one with most inliers is kept when it has more than min_inliers at
// min_inlier_ratio (Ma and Zhao, IEEE Access 2017; the CNN feature of the second seed).
class VerifiedPlaceRecognizer final : public PlaceRecognizer {
 public:
  // `descriptor_dimensions`: the descriptor model's output length (cnn and fusion; ignored by
  // bow). A view added with no descriptor (or one of another length) is left out of the
  // descriptor search: only the bag of words finds it, and missing_descriptors() counts it.
  VerifiedPlaceRecognizer(std::shared_ptr<const OrbVocabulary> vocabulary,
                          std::unique_ptr<MatchVerifier> verifier,
                          const PlaceRecognitionConfig& config, int descriptor_dimensions);

  PlaceOutcome recognise(const PlaceView& view, const PlaceFilter& filter) const override;
  std::vector<KeyframeKey> retrieve(const PlaceView& view, std::size_t max_results,
                                    const PlaceFilter& filter) const override;
  void add(const KeyframeKey& key, std::int64_t capture_time_ns, const PlaceView& view) override;
  PlaceOutcome recognise_then_add(const KeyframeKey& key, std::int64_t capture_time_ns,
                                  const PlaceView& view, const PlaceFilter& filter) override;
  std::size_t size() const override;
  std::size_t missing_descriptors() const;

 private:
  struct Entry {
    KeyframeKey key;
    std::int64_t capture_time_ns = 0;
    OrbFeatures features;
  };
  struct Ranked {
    std::vector<std::uint32_t> entries;
    std::vector<double> bow_scores, similarities;  // by position in entries; 0 where unknown
  };
  bool uses_descriptors() const { return mode_.ranks_by_descriptor(); }
  Ranked rank(const PlaceView& view, const BowVector& bow, std::size_t max_results,
              const PlaceFilter& filter) const;
  PlaceMatch verify(const OrbFeatures& query, const FeatureVector& query_direct,
                    std::uint32_t entry) const;
  // The view's bag of words and direct index (empty for a view without features).
  BowVector words(const PlaceView& view, FeatureVector& direct) const;
  PlaceOutcome recognise_words(const PlaceView& view, const BowVector& bow,
                               const FeatureVector& direct, const PlaceFilter& filter) const;
  void add_words(const KeyframeKey& key, std::int64_t capture_time_ns, const PlaceView& view,
                 const BowVector& bow, FeatureVector direct);

  std::shared_ptr<const OrbVocabulary> vocabulary_;
  std::unique_ptr<MatchVerifier> verifier_;
  PlaceRecognitionConfig config_;
  const RetrievalMode& mode_;
  mutable std::shared_mutex mutex_;
  BowDatabase database_;
  std::optional<DescriptorIndex> descriptors_;
  std::vector<bool> has_descriptor_;  // by entry: false = a zero row the search skips
  std::size_t missing_descriptors_ = 0;
  std::vector<Entry> entries_;  // indexed by the databases' entry id
};

}  // namespace keyfleet::station
