#pragma once
// ORB features as both sides of the link hold them. The robot's V-SLAM trigger and the
// station's place recognition extract them with different algorithms (grid_orb_extractor.hpp,
// orb_extractor.hpp), each tuned for its job, into this one type.
#include <opencv2/core.hpp>

#include <vector>

namespace keyfleet::vision {

struct OrbFeatures {
  std::vector<cv::KeyPoint> keypoints;  // input-image coordinates; octave = pyramid level
  cv::Mat descriptors;                  // CV_8U, one 32-byte row per keypoint
};

}  // namespace keyfleet::vision
