#include "keyfleet/station/station_analysis.hpp"

namespace keyfleet::station {
namespace {

MapNode node_of(const std::string& robot_id, std::uint64_t sequence, std::int64_t capture_time_ns,
                const std::optional<Pose>& pose) {
  MapNode node;
  node.robot_id = robot_id;
  node.sequence = sequence;
  node.capture_time_ns = capture_time_ns;
  node.pose = pose;
  return node;
}

}  // namespace

StationAnalysis::StationAnalysis(KeyframeStore& keyframes, AnalysisStore& store, TopoMap& map,
                                 AnalysisPool& pool, Logger logger)
    : keyframes_(keyframes), store_(store), map_(map), pool_(pool), logger_(std::move(logger)) {}

std::size_t rebuild_map(const KeyframeStore& keyframes, const AnalysisStore& store, TopoMap& map) {
  for (const StoredKeyframeInfo& k : keyframes.keyframe_index())
    map.add_keyframe(node_of(k.robot_id, k.sequence, k.capture_time_ns, k.pose));
  const std::vector<StoredWord> words = store.words();
  for (const StoredWord& w : words) {
    if (auto node = map.find(w.keyframe.robot_id, w.keyframe.sequence))
      map.add_words(*node, {w.text});
  }
  for (const StoredPlaceMatch& m : store.place_matches()) {
    const auto a = map.find(m.query.robot_id, m.query.sequence);
    const auto b = map.find(m.match.robot_id, m.match.sequence);
    const double ratio = m.matches ? double(m.inliers) / double(m.matches) : 0.0;
    if (a && b) map.add_place_match(*a, *b, PlaceLink{m.inliers, ratio, m.bow_score});
  }
  return words.size();
}

PlaceIndexRebuild rebuild_place_index(const AnalysisStore& store, PlaceRecognizer& places) {
  PlaceIndexRebuild rebuild;
  for (const auto& f : store.features()) {
    places.add(f.key, f.capture_time_ns, PlaceView{f.features, f.descriptor});
    ++rebuild.indexed;
    if (f.descriptor.empty()) ++rebuild.without_descriptor;
  }
  return rebuild;
}

void StationAnalysis::restore(PlaceRecognizer* places, bool descriptors_expected) {
  const std::size_t words = rebuild_map(keyframes_, store_, map_);
  const PlaceIndexRebuild index =
      places ? rebuild_place_index(store_, *places) : PlaceIndexRebuild{};
  backlog_ = true;
  if (map_.node_count() > 0) {
    logger_->info("restored {} keyframe(s), {} word(s), {} place match(es) and {} indexed place(s)",
                  map_.node_count(), words, map_.place_matches().size(), index.indexed);
  }
  if (index.without_descriptor > 0 && descriptors_expected)
    logger_->warn(
        "{} of the restored places have no stored descriptor (analysed with bow "
        "retrieval): only the bag of words retrieves them",
        index.without_descriptor);
}

std::size_t StationAnalysis::skip_abandoned(const AnalysisAttempts& attempts, int max_attempts) {
  const std::vector<AnalysisAttempts::Abandoned> abandoned = attempts.abandoned(max_attempts);
  for (const AnalysisAttempts::Abandoned& a : abandoned) {
    AnalysisResult skipped;
    skipped.key = a.key;
    skipped.capture_time_ns = a.capture_time_ns;
    skipped.status = AnalysisStatus::kFailed;
    skipped.detail = "its analysis was started " + std::to_string(a.attempts) +
                     " times and the station stopped during each (a crash in an engine?); "
                     "skipped, the keyframe itself is kept";
    logger_->error("analysis of {} skipped: {}", to_string(a.key), skipped.detail);
    store_.save(skipped);
  }
  return abandoned.size();
}

void StationAnalysis::on_stored(const Keyframe& k, const cv::Mat& decoded) {
  map_.add_keyframe(node_of(k.robot_id, k.sequence_number, k.capture_time_ns, k.camera_pose));
  AnalysisJob job = job_for(k, decoded);
  in_flight_.insert(job.key);
  pool_.submit(std::move(job));
}

void StationAnalysis::apply(const AnalysisResult& r) {
  in_flight_.erase(r.key);
  try {
    store_.save(r);
  } catch (const std::exception& e) {
    // Left unanalysed in the database: a restarted station analyses it again; this one does not
    // retry it (what failed once, a full disk or a bad row, fails again at once).
    unsaved_.insert(r.key);
    logger_->error("could not save the analysis of {} (analysed again at the next start): {}",
                   to_string(r.key), e.what());
    return;
  }
  switch (r.status) {
    case AnalysisStatus::kDeferred: backlog_ = true; return;
    case AnalysisStatus::kFailed:
      logger_->error("analysis of {} failed: {}", to_string(r.key), r.detail);
      return;
    case AnalysisStatus::kDone: break;
  }
  const auto node = map_.find(r.key.robot_id, r.key.sequence);
  if (!node) return;
  std::vector<std::string> words;
  for (const ReadWord& w : r.words) words.push_back(w.text);
  if (!words.empty()) map_.add_words(*node, words);
  if (r.place) {
    if (const auto other = map_.find(r.place->other.robot_id, r.place->other.sequence)) {
      map_.add_place_match(
          *node, *other, PlaceLink{r.place->inliers, r.place->inlier_ratio(), r.place->bow_score});
      logger_->info("{} shows the place of {} ({} inliers of {} matches{})", to_string(r.key),
                    to_string(r.place->other), r.place->inliers, r.place->matches,
                    r.place->other.robot_id != r.key.robot_id ? ", across robots" : "");
    }
  }
  logger_->debug(
      "analysed {}: {} word(s), {} candidate(s) checked, text {:.0f} ms ({:.0f} ms of CPU), "
      "places {:.0f} ms",
      to_string(r.key), r.words.size(), r.candidates_checked, r.text_ms, r.text_cpu_ms,
      r.places_ms);
}

void StationAnalysis::backfill() {
  std::vector<KeyframeKey> exclude(in_flight_.begin(), in_flight_.end());
  exclude.insert(exclude.end(), unsaved_.begin(), unsaved_.end());
  const std::vector<KeyframeKey> keys = store_.unanalysed(4, exclude);
  if (keys.empty()) {
    backlog_ = false;
    return;
  }
  for (const KeyframeKey& key : keys) {
    if (auto keyframe = keyframes_.load(key.robot_id, key.sequence)) {
      in_flight_.insert(key);
      pool_.submit(job_for(*keyframe));
    }
  }
}

std::size_t StationAnalysis::step() {
  const std::vector<AnalysisResult> results = pool_.take_results();
  for (const AnalysisResult& r : results) apply(r);
  if (backlog_ && pool_.idle()) backfill();
  return results.size();
}

bool StationAnalysis::drain(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    step();
    if (in_flight_.empty() && !backlog_ && pool_.idle()) return true;
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return false;
    pool_.wait_until_idle(std::min<std::chrono::milliseconds>(
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now),
        std::chrono::milliseconds(100)));
  }
}

StationAnalysis::Summary StationAnalysis::summary() const {
  Summary s;
  s.analysed = store_.count_with_status(AnalysisStatus::kDone);
  s.deferred = store_.count_with_status(AnalysisStatus::kDeferred);
  s.failed = store_.count_with_status(AnalysisStatus::kFailed);
  s.place_matches = map_.place_matches().size();
  s.cross_robot_matches = map_.cross_robot_match_count();
  return s;
}

}  // namespace keyfleet::station
