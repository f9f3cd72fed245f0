#pragma once
// Per-frame image quality, as the first seed (blur, exposure) and the second seed
// (sharpness) define it. Pure functions: no state, no threads.
#include <opencv2/core.hpp>

namespace keyfleet::agent {

// Energy of Laplacian of a grey image: the sum of squared responses of Pertuz et al.'s
// 3x3 kernel (1/6)[1 4 1; 4 -20 4; 1 4 1], replicated border. Higher = sharper.
double energy_of_laplacian(const cv::Mat& grey);

// 1 / sum((L - 50)^2) over the CIELAB lightness L in [0, 100] of a BGR image: a frame whose
// lightness sits around the middle scores high, over- and under-exposed ones low.
double brightness_score(const cv::Mat& bgr);

struct SharpnessParams {
  double edge_contrast = 180;  // summed first differences over 3x3 (mean 20 grey levels)
  double sharp_ratio = 0.8;    // difference-of-differences / first-difference of a sharp edge
};

// Kumar et al. (2012) sharpness: on a 3x3 median-filtered grey image, per direction, the
// first difference |I(i+1) - I(i-1)| (edge contrast) and the difference of differences
// |I(i+2) - 2 I(i) + I(i-2)|, each summed over a 3x3 window. An edge pixel is sharp where
// the ratio of the second sum to the first exceeds sharp_ratio; Rx and Ry are the sharp
// fractions of the edge pixels. The score is min(Rx, Ry) in [0, 1], not the combined
// sqrt(Rx^2 + Ry^2) / sqrt(2): motion blur smears one direction and leaves the other sharp,
// and the combined score then stays high (measured on the ten ICDAR photos at 320 px:
// 8-px blurred copies 0.59-0.89 against 0.86-0.98 sharp). With min(Rx, Ry) and these
// thresholds: sharp >= 0.75, 4 px <= 0.52, 8 px <= 0.27, so the seed's 0.5 gate separates.
double kumar_sharpness(const cv::Mat& grey, const SharpnessParams& params = {});

}  // namespace keyfleet::agent
