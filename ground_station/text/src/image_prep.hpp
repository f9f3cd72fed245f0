#pragma once
// Image preparation shared by the readers.
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/station/text_reader.hpp"

namespace keyfleet::station {

// An 8-bit greyscale copy of a BGR, BGRA or grey image; empty when the input is unusable
// (empty, not 8-bit, other channel counts, smaller than `min_side` pixels).
cv::Mat to_grey(const cv::Mat& image, int min_side = 4);

// The factor that brings the image's longer side into [min_long_side, max_long_side].
double reading_scale(cv::Size size, int min_long_side, int max_long_side);

cv::Mat rescaled(const cv::Mat& image, double scale);

// Boxes read on an image scaled by `scale` and offset by `origin` (in the original's
// pixels), mapped back to the original and clipped to `bounds`.
void map_back(std::vector<ReadWord>& words, double scale, cv::Point origin, cv::Rect bounds);

}  // namespace keyfleet::station
