#pragma once
// Place retrieval measured as the second seed measures it (`keyfleet places eval`): recall@1/@5
// of the retrieved candidates and the accuracy of the verified answer, per retrieval mode (bow,
// cnn, fusion), on generated two-day streets and the real vpr_corridor, with the queries as
// captured, motion-blurred and darkened.
#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"

namespace keyfleet::eval {

struct PlaceEvalSettings {
  // Vocabulary, descriptor model and verification as the station runs them; `retrieval` is
  // replaced by each of `modes` in turn.
  PlaceRecognitionConfig places;
  std::vector<PlaceRetrieval> modes = {PlaceRetrieval::kBow, PlaceRetrieval::kCnn,
                                       PlaceRetrieval::kFusion};
  int database_every = 5;    // every n-th frame of the first day's drones is a stored keyframe
  int query_every = 10;      // every n-th frame of the other days' drones is a query
  double tolerance_m = 5.0;  // right when the retrieved frame looks within this street distance
  double blur_px = 15;       // the blurred queries: linear motion blur this long (at 640 px wide)
  double dark_gain = 0.4;    // the darkened queries: pixel values times this
};

struct RetrievalScore {
  std::string dataset;      // "side-21", "corridor", ...
  std::string condition;    // "as captured", "motion blur", "dark"
  std::string mode;         // bow, cnn, fusion
  std::size_t queries = 0;  // answerable: some stored keyframe is right
  std::size_t top1 = 0, top5 = 0;
  std::size_t accepted = 0;        // queries whose best candidate passed verification
  std::size_t accepted_right = 0;  // ... and is right
  double recognise_ms = 0;         // median per query: retrieval + verification

  double recall1() const { return queries ? double(top1) / double(queries) : 0.0; }
  double recall5() const { return queries ? double(top5) / double(queries) : 0.0; }
  // Right verified answers over all answerable queries (no answer counts as wrong).
  double verified() const { return queries ? double(accepted_right) / double(queries) : 0.0; }
  double precision() const { return accepted ? double(accepted_right) / double(accepted) : 0.0; }
};

struct PlaceEvalCost {
  std::vector<double> describe_ms;  // per view, one thread
  std::vector<double> orb_ms;       // per view
};
double median(std::vector<double> samples);  // 0 for none

// The first day's drones store keyframes, the other days' drones query them.
std::vector<RetrievalScore> evaluate_places_on_scenario(const std::string& scenario_dir,
                                                        const std::string& dataset,
                                                        const PlaceEvalSettings& settings,
                                                        PlaceEvalCost& cost, Logger logger);

// vpr_corridor: the reference frames are stored, the query frames query them; right when the
// retrieved frame is one of ground_truth.csv's for the query. ORB on frames upscaled to 320 px.
std::vector<RetrievalScore> evaluate_places_on_corridor(const std::string& corridor_dir,
                                                        const PlaceEvalSettings& settings,
                                                        PlaceEvalCost& cost, Logger logger);

// Median ms of one exact descriptor query over `entries` random unit vectors.
double descriptor_query_ms(std::size_t entries, int dimensions, int repeats = 200);

// The queries' degradations: linear motion blur of `length_px` at `angle_deg`, and a gain.
cv::Mat motion_blurred(const cv::Mat& bgr, double length_px, double angle_deg);
cv::Mat exposure_scaled(const cv::Mat& bgr, double gain);

}  // namespace keyfleet::eval
