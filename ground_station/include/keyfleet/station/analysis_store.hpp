#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/station/analysis_types.hpp"

namespace keyfleet::station {

struct StoredWord {
  KeyframeKey keyframe;
  std::int64_t capture_time_ns = 0;
  std::string text;
  double confidence = 0;
  cv::Rect box;
};

struct StoredPlaceMatch {
  KeyframeKey query;  // the later keyframe
  KeyframeKey match;  // the stored keyframe it was recognised in
  std::size_t matches = 0;
  std::size_t inliers = 0;
  double bow_score = 0;
};

// What was analysed, in the station's database (beside the keyframes table): analysis
// status per keyframe, words (with an FTS5 index), ORB features and place
// descriptors (so a restarted station rebuilds its place index without redoing either) and verified
// place matches.
class AnalysisStore {
 public:
  // As KeyframeStore: kReadOnly creates no schema and writes nothing.
  explicit AnalysisStore(const std::string& path, SqliteDb::Mode mode = SqliteDb::Mode::kReadWrite);

  // One transaction per result; a later kDone replaces an earlier kDeferred.
  void save(const AnalysisResult& result);

  // Stored keyframes not analysed yet (never queued, deferred or interrupted), oldest
  // received first, skipping those in `exclude` (in flight).
  std::vector<KeyframeKey> unanalysed(std::size_t limit,
                                      const std::vector<KeyframeKey>& exclude = {}) const;

  // Full-text search (FTS5 syntax: HOTEL, hot*, "main street"), best first.
  std::vector<StoredWord> search_words(const std::string& query, std::size_t limit = 100) const;
  std::vector<StoredWord> words() const;
  std::vector<StoredPlaceMatch> place_matches() const;

  struct StoredFeatures {
    KeyframeKey key;
    std::int64_t capture_time_ns = 0;
    OrbFeatures features;
    std::vector<float> descriptor;  // the holistic place descriptor; empty when none was stored
  };
  // Every analysed keyframe's features, in the order they were analysed.
  std::vector<StoredFeatures> features() const;

  std::size_t count_with_status(AnalysisStatus status) const;

 private:
  mutable SqliteDb db_;
};

}  // namespace keyfleet::station
