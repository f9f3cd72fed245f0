#include "keyfleet/station/web/run_view.hpp"

#include <algorithm>
#include <map>

#include "keyfleet/station/map/topo_map.hpp"
#include "keyfleet/station/station_analysis.hpp"

namespace keyfleet::station::web {

RunView::RunView(const std::string& database)
    : keyframes_(database, SqliteDb::Mode::kReadOnly),
      analysis_(database, SqliteDb::Mode::kReadOnly) {}

BandwidthReport RunView::bandwidth_report() const {
  return build_bandwidth_report(keyframes_.totals());
}

std::vector<BandwidthSeries> RunView::bandwidth_timeline() const {
  return build_bandwidth_timeline(keyframes_.keyframe_index(), keyframes_.stats_history());
}

nlohmann::json RunView::summary(const std::optional<AnalysisPool::Counters>& live) const {
  nlohmann::json doc = nlohmann::json::parse(to_json(bandwidth_report()));
  const std::size_t stored = keyframes_.keyframe_count();
  const std::size_t done = analysis_.count_with_status(AnalysisStatus::kDone);
  const std::size_t deferred = analysis_.count_with_status(AnalysisStatus::kDeferred);
  const std::size_t failed = analysis_.count_with_status(AnalysisStatus::kFailed);
  const std::size_t accounted = done + deferred + failed;
  doc["keyframes"] = stored;
  doc["place_matches"] = analysis_.place_matches().size();
  doc["live"] = live.has_value();
  doc["analysis"] = {
      {"waiting", nullptr}, {"running", nullptr},
      {"done", done},       {"deferred", deferred},
      {"failed", failed},   {"unanalysed", stored > accounted ? stored - accounted : 0}};
  if (live) {
    doc["analysis"]["waiting"] = live->waiting;
    doc["analysis"]["running"] = live->running;
  }
  return doc;
}

std::vector<KeyframeCard> RunView::keyframes(const std::string& robot, std::size_t limit) const {
  std::vector<KeyframeCard> cards;
  const std::vector<StoredKeyframeInfo> index = keyframes_.keyframe_index();
  for (auto it = index.rbegin(); it != index.rend(); ++it) {
    if (!robot.empty() && it->robot_id != robot) continue;
    cards.push_back({*it, {}});
    if (limit && cards.size() == limit) break;
  }
  std::map<KeyframeKey, KeyframeCard*> by_key;
  for (KeyframeCard& c : cards) by_key[{c.info.robot_id, c.info.sequence}] = &c;
  for (StoredWord& w : analysis_.words()) {
    if (auto it = by_key.find(w.keyframe); it != by_key.end())
      it->second->words.push_back(std::move(w));
  }
  return cards;
}

std::vector<StoredWord> RunView::search(const std::string& query, std::size_t limit) const {
  return analysis_.search_words(query, limit);
}

nlohmann::json RunView::map() const {
  TopoMap map;
  rebuild_map(keyframes_, analysis_, map);
  return map.to_json();
}

std::optional<std::vector<std::uint8_t>> RunView::jpeg(const KeyframeKey& key) const {
  auto keyframe = keyframes_.load(key.robot_id, key.sequence);
  if (!keyframe) return std::nullopt;
  return std::move(keyframe->image);
}

}  // namespace keyfleet::station::web
