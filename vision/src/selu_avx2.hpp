#pragma once
// SELU over whole 8-float vectors with AVX2 and FMA (x86-64); internal to keyfleet_vision.
// OpenCV's cv::hal::exp32f takes about 0.5 ns a float here, three quarters of the vectorised
// SELU's time and so about 2 ms of MiniNet's forward pass at 512x256; this takes about 0.1 ns.

namespace keyfleet::vision {

// Writes selu(src[i]) to dst[i] for i < the returned count: n rounded down to a multiple of 8,
// or 0 where the CPU lacks AVX2 or FMA (the caller does the rest).
int selu_avx2(const float* src, float* dst, int n, float alpha, float gamma);

}  // namespace keyfleet::vision
