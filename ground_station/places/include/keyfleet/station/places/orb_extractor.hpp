#pragma once
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/vision/orb_features.hpp"

namespace keyfleet::station {

using vision::OrbFeatures;

// ORB for place recognition on received keyframes. Defaults follow ORB-SLAM2 (1000 corners,
// 8 levels, scale 1.2), with its lower FAST threshold (7) for every cell: the strongest corners
// of each cell are kept, so a sharp view keeps its strong corners, and a blurred or dark view
// keeps enough to be verified (chosen on PlaceNet's validation streets: verified top-1 with cnn
// retrieval of blurred queries 24 -> 70 % and 41 -> 73 %, sharp ones unchanged or better).
struct OrbParams {
  int features = 1000;
  float scale = 1.2f;
  int levels = 8;
  int fast_threshold = 7;
  // OpenCV's ORB over-detects by this factor, then the strongest corners are kept cell by cell
  // so that one textured corner of the image does not take the whole quota (1 = no spreading).
  float oversample = 2.0f;
  int cell_px = 40;  // spreading cell, in pixels of the (possibly upscaled) image
  // Images narrower than this are upscaled first (tiny frames leave no room inside ORB's
  // 31-pixel border); keypoints are reported in the input image's coordinates. 0 = never.
  int min_width = 0;
};

// ORB keypoints and descriptors of a BGR or grey image; an empty image gives no features and
// bad parameters give OpenCV's defaults rather than an exception (a per-keyframe path).
OrbFeatures extract_orb(const cv::Mat& image, const OrbParams& params);

}  // namespace keyfleet::station
