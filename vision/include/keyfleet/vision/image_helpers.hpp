#pragma once
// Small image helpers that the robot's and the station's vision code share.
#include <opencv2/core.hpp>

#include <vector>

namespace keyfleet::vision {

// An 8-bit greyscale view or copy of a BGR, BGRA or grey image (a grey input is returned as
// is, sharing its pixels); empty when the input is unusable: empty, not 8-bit, not 2-D, other
// channel counts, or either side smaller than `min_side` pixels.
cv::Mat to_grey(const cv::Mat& image, int min_side = 1);

// Spreads keypoints over a grid of `cell_px` square cells so that one textured corner of an
// image cannot take the whole quota: visits the keypoints in `strongest_first` order (indices
// into `keypoints`, strongest first) and keeps the strongest of every cell, then the second of
// every cell, and so on, until `quota` are kept. Returns the kept indices in the order kept.
std::vector<int> spread_over_grid(const std::vector<cv::KeyPoint>& keypoints,
                                  const std::vector<int>& strongest_first, cv::Size image_size,
                                  double cell_px, int quota);

}  // namespace keyfleet::vision
