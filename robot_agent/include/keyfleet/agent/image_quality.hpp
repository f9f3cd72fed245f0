#pragma once
// Per-frame image quality, as Alonso et al. 2019 (blur, exposure) and Ma and Zhao 2017
// (sharpness) define it. The free functions are pure; the workspace types only hold buffers
// (and tables) that the per-frame path reuses, one per selector: not shared between threads.
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace keyfleet::agent {

// Energy of Laplacian of an 8-bit grey image: the sum of squared responses of Pertuz et al.'s
// 3x3 kernel (1/6)[1 4 1; 4 -20 4; 1 4 1], replicated border. Higher = sharper. Computed in
// integers (the responses times 6, squared, summed, divided by 36), so it is exact.
double energy_of_laplacian(const cv::Mat& grey);

// 1 / (1 + sum((L - 50)^2)) over the CIELAB lightness L in [0, 100] of an 8-bit BGR image
// (OpenCV's 8-bit L, 255 steps): a frame whose lightness sits around the middle scores high,
// over- and under-exposed ones low. L is computed alone (lab_lightness), the same levels.
double brightness_score(const cv::Mat& bgr);

// OpenCV's 8-bit CIELAB L (0..255) of one BGR pixel, cv::cvtColor(COLOR_BGR2Lab)'s first channel
// to the level, without its a and b.
std::uint8_t lab_lightness(std::uint8_t b, std::uint8_t g, std::uint8_t r);

struct SharpnessParams {
  double edge_contrast = 180;  // summed first differences over 3x3 (mean 20 grey levels)
  double sharp_ratio = 0.8;    // difference-of-differences / first-difference of a sharp edge
};

// Buffers of kumar_sharpness, reused from frame to frame.
struct SharpnessScratch {
  cv::Mat padded_grey;                // the grey image, 1 replicated pixel around
  cv::Mat median;                     // its 3x3 median, 2 replicated pixels around
  std::vector<std::uint8_t> columns;  // sorted column triples of one row
  std::vector<std::int16_t> rows;     // differences and their horizontal sums, a few rows
};

// Kumar et al. (2012) sharpness: on a 3x3 median-filtered grey image, per direction, the
// first difference |I(i+1) - I(i-1)| (edge contrast) and the difference of differences
// |I(i+2) - 2 I(i) + I(i-2)| (replicated border), each summed over a 3x3 window (reflected
// border). An edge pixel is sharp where the ratio of the second sum to the first exceeds
// sharp_ratio; Rx and Ry are the sharp fractions of the edge pixels. The score is
// min(Rx, Ry) in [0, 1], not the combined sqrt(Rx^2 + Ry^2) / sqrt(2): motion blur smears
// one direction and leaves the other sharp, and the combined score then stays high (measured
// on the ten ICDAR photos at 320 px: 8-px blurred copies 0.59-0.89 against 0.86-0.98 sharp).
// With min(Rx, Ry) and these thresholds: sharp >= 0.75, 4 px <= 0.52, 8 px <= 0.27, so the
// 0.5 gate of Ma and Zhao (IEEE Access 2017) separates. One pass over 16-bit rows after the median
// (no float images); the same counts as the straightforward OpenCV formulation (filter2D,
// boxFilter, compare).
double kumar_sharpness(const cv::Mat& grey, const SharpnessParams& params,
                       SharpnessScratch& scratch);
double kumar_sharpness(const cv::Mat& grey, const SharpnessParams& params = {});

// cv::resize(..., INTER_AREA) for 8-bit images with 1 to 4 channels when shrinking: integer
// factors go to OpenCV's own fast path; other factors (320 -> 112 costs OpenCV's general path
// ~0.45 ms) to a separable pass in integers: with s = source / target = a / b in lowest
// terms, each source pixel overlaps an output pixel by a whole number of 1/b-ths, so the
// area average is an exact fraction, rounded half up. Rows first (16-bit sums, a x 255 must
// fit), then columns; the tables are kept for the next frame of the same size. Other
// ratios go to OpenCV. Within one grey level of OpenCV (which sums in float).
class AreaResizer {
 public:
  void resize(const cv::Mat& src, cv::Mat& dst, cv::Size size);

 private:
  struct Taps {  // per output index: the first source index and `count` overlaps
    std::vector<int> first;
    std::vector<std::uint16_t> overlaps;  // in 1/b-ths of a pixel, `count` per index, 0-padded
    int count = 0;
    int sum = 0;  // the overlaps of each output index add up to a
  };
  static Taps taps(int source, int target);

  cv::Size from_, to_;
  bool exact_ = false;  // the sizes' ratios fit the integer pass
  Taps x_, y_;
  std::uint64_t reciprocal_ = 0;     // (n * reciprocal_) >> 32 == n / (x_.sum * y_.sum)
  std::vector<std::uint16_t> rows_;  // one output row's vertical sums, all source columns
};

// The images one frame is scored on, and the buffers that make them, reused per frame.
struct QualityImages {
  cv::Mat work;       // the frame area-resized to the sharpness width (or the frame itself)
  cv::Mat work_grey;  // its grey copy: the sharpness is measured on it
  cv::Mat small;      // size x size, area-resized from `work`: brightness
  cv::Mat grey;       // its grey copy: blur
  AreaResizer to_width, to_size;
  cv::Mat resized;
  SharpnessScratch sharpness;

  // Fills work, work_grey, small and grey from a BGR frame (never upscales to the width).
  void prepare(const cv::Mat& bgr, int size, int sharpness_width);
};

}  // namespace keyfleet::agent
