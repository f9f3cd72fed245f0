#pragma once
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <vector>

#include "keyfleet/vision/orb_features.hpp"

namespace keyfleet::agent {

using vision::OrbFeatures;

struct GridOrbParams {
  int features = 1000;
  int levels = 8;
  double scale_factor = 1.2;
  int initial_fast_threshold = 20;  // per cell; lowered to min_fast_threshold where none found
  int min_fast_threshold = 7;
  int cell_px = 30;
};

// ORB features spread over the image as ORB-SLAM2 spreads them: a scale pyramid with a
// per-level quota, FAST per grid cell with a threshold lowered where a cell is empty, the
// strongest corners kept cell by cell, orientation by intensity centroid, rBRIEF descriptors
// (OpenCV's ORB on the given keypoints).
class GridOrbExtractor {
 public:
  explicit GridOrbExtractor(const GridOrbParams& params);
  OrbFeatures extract(const cv::Mat& grey) const;

 private:
  GridOrbParams params_;
  std::vector<int> per_level_;
  cv::Ptr<cv::Feature2D> describer_;
};

}  // namespace keyfleet::agent
