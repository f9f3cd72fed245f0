#pragma once
#include <opencv2/core.hpp>

namespace keyfleet::agent {

// sum(Text) / (1 + sum(Text in the border band)): text cut by the frame edge is likely a
// partial sign, so text near the border counts against the frame. `border` is the band's
// width as a fraction of the mask's smaller side.
double semantic_score(const cv::Mat& text_mask, double border);

}  // namespace keyfleet::agent
