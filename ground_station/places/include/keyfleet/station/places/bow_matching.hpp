#pragma once
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/station/places/bow_types.hpp"

namespace keyfleet::station {

// Descriptor matches between two images compared only within shared vocabulary nodes (the
// direct indices of OrbVocabulary::transform): best distance <= max_hamming, Lowe's ratio
// against the second best in the node, then one-to-one (the closer query keeps a train row).
// queryIdx / trainIdx are descriptor rows; sorted by queryIdx. Bad input gives no matches.
std::vector<cv::DMatch> match_with_direct_index(const cv::Mat& query_desc,
                                                const FeatureVector& query_fv,
                                                const cv::Mat& train_desc,
                                                const FeatureVector& train_fv, int max_hamming = 50,
                                                float ratio = 0.8f);

}  // namespace keyfleet::station
