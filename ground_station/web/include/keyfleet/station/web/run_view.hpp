#pragma once
#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/station/analysis_pool.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/bandwidth_report.hpp"
#include "keyfleet/station/keyframe_store.hpp"

namespace keyfleet::station::web {

// A stored keyframe with the words read in it (empty until analysed).
struct KeyframeCard {
  StoredKeyframeInfo info;
  std::vector<StoredWord> words;
};

// What the dashboard and report.html show of a run, read from the station's database through
// read-only connections (safe beside the station writing it, or on a finished run's file).
// Not thread-safe: the owner serialises calls.
class RunView {
 public:
  explicit RunView(const std::string& database);  // throws SqliteError when it cannot open

  // {"robots": [bandwidth rows as report.json], "fleet": {...}, "analysis": {"waiting",
  //  "running", "done", "deferred", "failed", "unanalysed"}, "keyframes", "place_matches",
  //  "live"}. `live` is the running station's queue; without it waiting/running are null.
  nlohmann::json summary(const std::optional<AnalysisPool::Counters>& live) const;
  BandwidthReport bandwidth_report() const;
  std::vector<BandwidthSeries> bandwidth_timeline() const;

  // A robot's latest `limit` keyframes (by receive time), newest first; all robots when
  // `robot` is empty and `limit` is 0.
  std::vector<KeyframeCard> keyframes(const std::string& robot, std::size_t limit) const;
  // FTS5 search (throws SqliteError on bad syntax), best first, at most `limit` words.
  std::vector<StoredWord> search(const std::string& query, std::size_t limit) const;
  // The topological map as TopoMap::to_json, rebuilt from the database.
  nlohmann::json map() const;
  std::optional<std::vector<std::uint8_t>> jpeg(const KeyframeKey& key) const;

 private:
  KeyframeStore keyframes_;
  AnalysisStore analysis_;
};

}  // namespace keyfleet::station::web
