#include "keyfleet/station/place_recognizer.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>

#include "keyfleet/station/places/bow_matching.hpp"

namespace keyfleet::station {

PlaceFilter not_a_recent_neighbour(const KeyframeKey& query, std::int64_t capture_time_ns,
                                   double exclusion_s) {
  const auto exclusion_ns = static_cast<std::int64_t>(exclusion_s * 1e9);
  return [robot = query.robot_id, capture_time_ns, exclusion_ns](const KeyframeKey& key,
                                                                 std::int64_t t) {
    return key.robot_id != robot || std::llabs(t - capture_time_ns) >= exclusion_ns;
  };
}

OrbBowPlaceRecognizer::OrbBowPlaceRecognizer(std::shared_ptr<const OrbVocabulary> vocabulary,
                                             std::unique_ptr<MatchVerifier> verifier,
                                             const PlaceRecognitionConfig& config)
    : vocabulary_(std::move(vocabulary)), verifier_(std::move(verifier)), config_(config) {}

PlaceMatch OrbBowPlaceRecognizer::verify(const OrbFeatures& query,
                                         const FeatureVector& query_direct, std::uint32_t entry,
                                         double bow_score) const {
  const Entry& candidate = entries_[entry];
  PlaceMatch match;
  match.other = candidate.key;
  match.bow_score = bow_score;
  const std::vector<cv::DMatch> pairs =
      match_with_direct_index(query.descriptors, query_direct, candidate.features.descriptors,
                              database_.direct_index(entry));
  match.matches = pairs.size();
  if (pairs.size() <= static_cast<std::size_t>(config_.min_inliers)) return match;
  std::vector<cv::Point2f> from, to;
  from.reserve(pairs.size());
  to.reserve(pairs.size());
  for (const cv::DMatch& m : pairs) {
    from.push_back(query.keypoints[m.queryIdx].pt);
    to.push_back(candidate.features.keypoints[m.trainIdx].pt);
  }
  match.inliers = verifier_->verify(from, to).inliers.size();
  return match;
}

PlaceOutcome OrbBowPlaceRecognizer::recognise(const OrbFeatures& features,
                                              const PlaceFilter& filter) const {
  PlaceOutcome outcome;
  if (features.descriptors.empty()) return outcome;
  FeatureVector direct;
  const BowVector bow = vocabulary_->transform(features.descriptors, &direct);
  std::shared_lock lock(mutex_);
  const auto accept = [&](std::uint32_t entry) {
    return !filter || filter(entries_[entry].key, entries_[entry].capture_time_ns);
  };
  for (const BowMatch& candidate :
       database_.query(bow, static_cast<std::size_t>(config_.candidates), accept)) {
    PlaceMatch match = verify(features, direct, candidate.entry, candidate.score);
    const bool accepted = match.inliers > static_cast<std::size_t>(config_.min_inliers) &&
                          match.inlier_ratio() > config_.min_inlier_ratio;
    if (accepted && (!outcome.best || match.inliers > outcome.best->inliers)) outcome.best = match;
    outcome.checked.push_back(std::move(match));
  }
  return outcome;
}

void OrbBowPlaceRecognizer::add(const KeyframeKey& key, std::int64_t capture_time_ns,
                                const OrbFeatures& features) {
  FeatureVector direct;
  const BowVector bow = vocabulary_->transform(features.descriptors, &direct);
  std::unique_lock lock(mutex_);
  database_.add(bow, std::move(direct));  // entry ids count up from 0, like entries_
  entries_.push_back(Entry{key, capture_time_ns, features});
}

std::size_t OrbBowPlaceRecognizer::size() const {
  std::shared_lock lock(mutex_);
  return entries_.size();
}

}  // namespace keyfleet::station
