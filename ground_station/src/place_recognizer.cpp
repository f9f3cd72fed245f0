#include "keyfleet/station/place_recognizer.hpp"

#include <algorithm>
#include <cmath>
#include <map>
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

VerifiedPlaceRecognizer::VerifiedPlaceRecognizer(std::shared_ptr<const OrbVocabulary> vocabulary,
                                                 std::unique_ptr<MatchVerifier> verifier,
                                                 const PlaceRecognitionConfig& config,
                                                 int descriptor_dimensions)
    : vocabulary_(std::move(vocabulary)),
      verifier_(std::move(verifier)),
      config_(config),
      mode_(retrieval_mode(config.retrieval)) {
  if (uses_descriptors()) descriptors_.emplace(descriptor_dimensions);
}

VerifiedPlaceRecognizer::Ranked VerifiedPlaceRecognizer::rank(const PlaceView& view,
                                                              const BowVector& bow,
                                                              std::size_t max_results,
                                                              const PlaceFilter& filter) const {
  const auto accept = [&](std::uint32_t entry) {
    return !filter || filter(entries_[entry].key, entries_[entry].capture_time_ns);
  };
  const std::size_t depth = mode_.depth(max_results, config_);
  std::map<std::uint32_t, double> bow_scores, similarities;
  std::vector<std::uint32_t> by_bow, by_descriptor;
  if (mode_.ranks_by_bow() && !bow.empty()) {
    for (const BowMatch& m : database_.query(bow, depth, accept)) {
      by_bow.push_back(m.entry);
      bow_scores[m.entry] = m.score;
    }
  }
  // A query without a descriptor (or one of another model's length) finds nothing here.
  if (descriptors_ &&
      view.descriptor.size() == static_cast<std::size_t>(descriptors_->dimensions())) {
    const auto described = [&](std::uint32_t entry) {
      return has_descriptor_[entry] && accept(entry);
    };
    for (const DescriptorMatch& m : descriptors_->query(view.descriptor, depth, described)) {
      by_descriptor.push_back(m.entry);
      similarities[m.entry] = m.similarity;
    }
  }
  Ranked ranked;
  ranked.entries = mode_.combine(by_bow, by_descriptor);
  if (ranked.entries.size() > max_results) ranked.entries.resize(max_results);
  for (std::uint32_t e : ranked.entries) {
    ranked.bow_scores.push_back(bow_scores.count(e) ? bow_scores[e] : 0.0);
    ranked.similarities.push_back(similarities.count(e) ? similarities[e] : 0.0);
  }
  return ranked;
}

PlaceMatch VerifiedPlaceRecognizer::verify(const OrbFeatures& query,
                                           const FeatureVector& query_direct,
                                           std::uint32_t entry) const {
  const Entry& candidate = entries_[entry];
  PlaceMatch match;
  match.other = candidate.key;
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

BowVector VerifiedPlaceRecognizer::words(const PlaceView& view, FeatureVector& direct) const {
  return view.features.descriptors.empty()
             ? BowVector{}
             : vocabulary_->transform(view.features.descriptors, &direct);
}

PlaceOutcome VerifiedPlaceRecognizer::recognise(const PlaceView& view,
                                                const PlaceFilter& filter) const {
  FeatureVector direct;
  const BowVector bow = words(view, direct);
  return recognise_words(view, bow, direct, filter);
}

PlaceOutcome VerifiedPlaceRecognizer::recognise_words(const PlaceView& view, const BowVector& bow,
                                                      const FeatureVector& direct,
                                                      const PlaceFilter& filter) const {
  PlaceOutcome outcome;
  std::shared_lock lock(mutex_);
  const Ranked ranked = rank(view, bow, static_cast<std::size_t>(config_.candidates), filter);
  for (std::size_t i = 0; i < ranked.entries.size(); ++i) {
    PlaceMatch match = view.features.descriptors.empty()
                           ? PlaceMatch{}
                           : verify(view.features, direct, ranked.entries[i]);
    match.other = entries_[ranked.entries[i]].key;
    match.bow_score = ranked.bow_scores[i];
    match.descriptor_similarity = ranked.similarities[i];
    const bool accepted = match.inliers > static_cast<std::size_t>(config_.min_inliers) &&
                          match.inlier_ratio() > config_.min_inlier_ratio;
    if (accepted && (!outcome.best || match.inliers > outcome.best->inliers)) outcome.best = match;
    outcome.checked.push_back(std::move(match));
  }
  return outcome;
}

std::vector<KeyframeKey> VerifiedPlaceRecognizer::retrieve(const PlaceView& view,
                                                           std::size_t max_results,
                                                           const PlaceFilter& filter) const {
  // Without verification, a mode that does not rank by it needs no bag of words.
  const BowVector bow = !mode_.ranks_by_bow() || view.features.descriptors.empty()
                            ? BowVector{}
                            : vocabulary_->transform(view.features.descriptors);
  std::shared_lock lock(mutex_);
  std::vector<KeyframeKey> keys;
  for (std::uint32_t e : rank(view, bow, max_results, filter).entries)
    keys.push_back(entries_[e].key);
  return keys;
}

void VerifiedPlaceRecognizer::add(const KeyframeKey& key, std::int64_t capture_time_ns,
                                  const PlaceView& view) {
  FeatureVector direct;
  const BowVector bow = words(view, direct);
  add_words(key, capture_time_ns, view, bow, std::move(direct));
}

PlaceOutcome VerifiedPlaceRecognizer::recognise_then_add(const KeyframeKey& key,
                                                         std::int64_t capture_time_ns,
                                                         const PlaceView& view,
                                                         const PlaceFilter& filter) {
  FeatureVector direct;
  const BowVector bow = words(view, direct);
  PlaceOutcome outcome = recognise_words(view, bow, direct, filter);
  add_words(key, capture_time_ns, view, bow, std::move(direct));
  return outcome;
}

void VerifiedPlaceRecognizer::add_words(const KeyframeKey& key, std::int64_t capture_time_ns,
                                        const PlaceView& view, const BowVector& bow,
                                        FeatureVector direct) {
  std::unique_lock lock(mutex_);
  database_.add(bow, std::move(direct));  // entry ids count up from 0, like entries_
  if (descriptors_) {
    const auto dimensions = static_cast<std::size_t>(descriptors_->dimensions());
    const bool described = view.descriptor.size() == dimensions;
    descriptors_->add(described ? view.descriptor : std::vector<float>(dimensions, 0.0f));
    has_descriptor_.push_back(described);
    if (!described) ++missing_descriptors_;
  }
  entries_.push_back(Entry{key, capture_time_ns, view.features});
}

std::size_t VerifiedPlaceRecognizer::size() const {
  std::shared_lock lock(mutex_);
  return entries_.size();
}

std::size_t VerifiedPlaceRecognizer::missing_descriptors() const {
  std::shared_lock lock(mutex_);
  return missing_descriptors_;
}

}  // namespace keyfleet::station
