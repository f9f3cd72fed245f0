#pragma once
#include <opencv2/core.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "keyfleet/common/types.hpp"
#include "keyfleet/station/places/orb_extractor.hpp"
#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::station {

// A stored keyframe, as the station names it everywhere.
struct KeyframeKey {
  std::string robot_id;
  std::uint64_t sequence = 0;
  bool operator==(const KeyframeKey& o) const {
    return sequence == o.sequence && robot_id == o.robot_id;
  }
  bool operator<(const KeyframeKey& o) const {
    return std::tie(robot_id, sequence) < std::tie(o.robot_id, o.sequence);
  }
};

std::string to_string(const KeyframeKey& key);  // "drone_0#12"

// What the analysis of one stored keyframe needs.
struct AnalysisJob {
  KeyframeKey key;
  std::int64_t capture_time_ns = 0;
  std::optional<Pose> pose;
  std::vector<std::uint8_t> jpeg;
  std::vector<TextRegion> text_regions;  // the robot's hints, as the station checked them
  cv::Mat image;  // the JPEG's pixels where the station's check decoded them; empty: decode `jpeg`
};

// `decoded`: the keyframe's pixels, when at hand (a job queued at once), else empty.
AnalysisJob job_for(const Keyframe& keyframe, cv::Mat decoded = {});

// A verified place match: this keyframe shows the place `other` shows.
struct PlaceMatch {
  KeyframeKey other;
  double bow_score = 0;     // 0 when the bag of words did not rank it (cnn retrieval)
  std::size_t matches = 0;  // ORB descriptor matches handed to the verifier
  std::size_t inliers = 0;
  double descriptor_similarity = 0;  // cosine; 0 when no descriptor ranked it (bow retrieval)
  double inlier_ratio() const { return matches ? double(inliers) / double(matches) : 0.0; }
};

enum class AnalysisStatus {
  kDone,      // text and places analysed
  kDeferred,  // queue overloaded: heavy steps postponed until the station is idle (or restarts)
  kFailed,    // the image could not be decoded (it passed validation, so this is unexpected)
};

struct AnalysisResult {
  KeyframeKey key;
  std::int64_t capture_time_ns = 0;
  AnalysisStatus status = AnalysisStatus::kDone;
  std::string detail;  // why deferred or failed
  std::vector<ReadWord> words;
  std::optional<OrbFeatures> features;
  std::vector<float> descriptor;    // the holistic place descriptor (empty with bow retrieval)
  std::optional<PlaceMatch> place;  // the best verified match, when one passed
  std::size_t candidates_checked = 0;
  double text_ms = 0;      // reading the text, wall clock (waits for the CPU included)
  double text_cpu_ms = 0;  // the same, CPU time of the worker's thread (the reader's own threads,
                           // with analysis.text.threads above 1, not counted)
  double places_ms = 0;
};

const char* to_string(AnalysisStatus status);

}  // namespace keyfleet::station
