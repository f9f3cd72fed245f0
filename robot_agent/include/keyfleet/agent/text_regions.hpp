#pragma once
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// Coarse text regions of a frame from its text mask (CV_8U, non-zero = text, at the
// segmenter's size, which may differ from the frame's in either direction): connected
// components, those under `min_area_px` frame pixels dropped, those side by side on one line
// merged, in frame pixels (rounded outwards, inside the frame), largest first, at most
// `max_regions`. None when disabled or the mask is empty.
std::vector<TextRegion> text_regions(const cv::Mat& text_mask, cv::Size frame_size,
                                     const TextRegionsConfig& config);

}  // namespace keyfleet::agent
