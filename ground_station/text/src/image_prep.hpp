#pragma once
// Image preparation shared by the readers.
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::station {

// The factor that brings the image's longer side into [min_long_side, max_long_side].
double reading_scale(cv::Size size, int min_long_side, int max_long_side);

cv::Mat rescaled(const cv::Mat& image, double scale);

// Boxes read on an image scaled by `scale` and offset by `origin` (in the original's
// pixels), mapped back to the original and clipped to `bounds`.
void map_back(std::vector<ReadWord>& words, double scale, cv::Point origin, cv::Rect bounds);

}  // namespace keyfleet::station
