#pragma once
#include <chrono>
#include <set>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_attempts.hpp"
#include "keyfleet/station/analysis_pool.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/map/topo_map.hpp"
#include "keyfleet/station/place_recognizer.hpp"

namespace keyfleet::station {

// Rebuilds the map from the database: every stored keyframe, the words read, the place
// matches. Returns the number of words.
std::size_t rebuild_map(const KeyframeStore& keyframes, const AnalysisStore& store, TopoMap& map);

struct PlaceIndexRebuild {
  std::size_t indexed = 0;
  std::size_t without_descriptor = 0;  // stored before a descriptor model was used
};
// Adds every analysed keyframe's stored features and descriptor to the place index.
PlaceIndexRebuild rebuild_place_index(const AnalysisStore& store, PlaceRecognizer& places);

// Ties the analysis together on the station's main thread: stored keyframes become map
// nodes and analysis jobs; results are saved and linked into the map; when the pool is
// idle, keyframes left unanalysed (deferred under overload, or interrupted by a restart)
// are loaded from the database and analysed.
class StationAnalysis {
 public:
  StationAnalysis(KeyframeStore& keyframes, AnalysisStore& store, TopoMap& map, AnalysisPool& pool,
                  Logger logger);

  // Rebuilds the map and the place index from the database (a restarted station).
  // `descriptors_expected`: the retrieval uses descriptors (warns about places stored without).
  void restore(PlaceRecognizer* places, bool descriptors_expected = false);
  // Marks failed, with the reason, each keyframe whose analysis was started max_attempts times
  // without a result (it ended the station each time), so that it is not analysed again.
  // Returns how many.
  std::size_t skip_abandoned(const AnalysisAttempts& attempts, int max_attempts);
  // `decoded`: its pixels where the station's check decoded them (else the analysis decodes).
  void on_stored(const Keyframe& keyframe, const cv::Mat& decoded = {});
  // Saves finished results, backfills when idle. Returns the number of results saved.
  std::size_t step();
  // Runs step() until nothing is queued or unanalysed, or `timeout` passes.
  bool drain(std::chrono::milliseconds timeout);

  struct Summary {
    std::size_t analysed = 0, deferred = 0, failed = 0, place_matches = 0, cross_robot_matches = 0;
  };
  Summary summary() const;

 private:
  void apply(const AnalysisResult& result);
  void backfill();

  KeyframeStore& keyframes_;
  AnalysisStore& store_;
  TopoMap& map_;
  AnalysisPool& pool_;
  Logger logger_;
  std::set<KeyframeKey> in_flight_;
  // Analyses that could not be saved in this run: left unanalysed for the next start, not
  // analysed again now (the backlog would otherwise resubmit them in a loop).
  std::set<KeyframeKey> unsaved_;
  bool backlog_ = true;  // there may be unanalysed keyframes in the database
};

}  // namespace keyfleet::station
