#pragma once
// A nearest upsampling whose output only an element-wise sum reads, where the sum runs right after
// it (PP-OCR's FPN: a + up(b) three times, the last over 96 x 120 x 160 at 640x480): the
// upsampling stand-in leaves its output unwritten and hands the sum stand-in its input, and the
// sum adds each widened input row straight into its output rows. The same floats; the upsampled
// map (7.4 MB at 640x480) is neither written nor read back. The sum checks the hand-over against
// its inputs on every pass and, where it cannot add that way (another geometry, three inputs, its
// output over the upsampling's input), upsamples into the waiting blob first, as unfused.
// The same for a 3x3 convolution stand-in that alone reads a concatenation of channels (OpenCV
// writes each input of a concatenation straight into its slice of the output, so the convolution
// reads the slices in place): an upsampling by kTapsFromFactor or more each way into that
// concatenation leaves its slice unwritten and hands the convolution a copy of its input, whose
// share the convolution computes at that size (upsampled_taps.hpp). The convolution checks each
// hand-over against its input on every pass and writes any it cannot take into its slice first.
// Internal to keyfleet_vision (nearest_upsampling.cpp, elementwise_sum.cpp,
// upsampled_concatenation.cpp).
#include <opencv2/core.hpp>

#include <memory>

namespace keyfleet::vision {

struct UpsamplingHandOver {
  cv::Mat source;  // the upsampling's input (a header on OpenCV's blob; a copy for a slice)
  cv::Mat target;  // its output blob, left unwritten; empty when nothing waits
  bool waiting() const { return !target.empty(); }
};

// The sum stand-in's side: an upsampling that runs right before it and feeds only it.
class UpsamplingReader {
 public:
  virtual ~UpsamplingReader() = default;
  virtual void read_upsampling(std::shared_ptr<UpsamplingHandOver> hand_over) = 0;
};

// The smallest factor (each way) whose slice an upsampling hands a convolution: at 2 the nine taps'
// products at the small size cost about what Winograd's F(4x4, 3x3) does at the large one (9/4
// against 36/16 multiplications an output pixel), and the rows' sums come on top.
constexpr int kTapsFromFactor = 4;

// The convolution's side: it alone reads the concatenation the upsampling writes a slice of.
class SliceReader {
 public:
  virtual ~SliceReader() = default;
  // Whether it takes the hand-over (a convolution in bfloat16 does not).
  virtual bool read_upsampled_slice(std::shared_ptr<UpsamplingHandOver> hand_over) = 0;
};

// Whether m is a 4-D float blob whose planes are each contiguous (its images may lie apart: an
// output may be a slice of a concatenation's channels).
bool planes_contiguous(const cv::Mat& m);

// dst = a + b, n floats in SIMD (dst may be a or b).
void add_floats(const float* a, const float* b, float* dst, int n);

// dst[x * k + j] = src[x] for x < n, j < k.
void repeat_columns(const float* src, int n, int k, float* dst);

// Whether `out` is `in` upsampled by powers of two in each direction: 4-D float blobs of the same
// images and channels, `in` continuous, each of `out`'s planes contiguous.
bool upsamples_by_powers_of_two(const cv::Mat& in, const cv::Mat& out);

// out = in upsampled (upsamples_by_powers_of_two(in, out) holds).
void upsample_nearest(const cv::Mat& in, cv::Mat& out);

}  // namespace keyfleet::vision
