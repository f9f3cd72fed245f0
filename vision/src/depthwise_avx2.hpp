#pragma once
// One plane of a depthwise convolution with AVX2 and FMA (x86-64); internal to
// keyfleet_vision (dnn_layers.cpp's depthwise stand-in). Each output vector sums all its taps in
// registers and is stored once: the plane-at-a-time way (a pass over the output per tap) reads and
// writes the output plane kh x kw times, which costs more than the multiplications on PP-OCR's
// large planes (16 channels of 240x320 in its detector's first block at 640x480).

namespace keyfleet::vision {

// Whether this CPU runs depthwise_plane_avx2 (x86-64 with AVX2 and FMA).
bool depthwise_avx2_supported();

// dst (ho x wo) = bias + sum over taps (ky, kx) of kernel[ky * kw + kx] times src (h x w) at
// (y sh - pt + ky dh, x sw - pl + kx dw), zero outside src (sh: the stride down columns, sw along
// rows: 1 or 2), over a copy of the plane with a zero border (with sw 2, its even and odd
// columns apart). Kernels of 3 or 5 rows without dilation and without zero taps (PP-OCR's) load
// each input vector once for the up to 4 output rows it feeds and sum the taps kernel column by
// column (kx, then ky); other kernels skip their zero taps and sum in the order ky, kx (as the
// portable code does). Either way an output's sum does not depend on which rows are computed
// together (a band of rows gives the whole plane's floats). Requires depthwise_avx2_supported().
void depthwise_plane_avx2(const float* src, int h, int w, const float* kernel, int kh, int kw,
                          int dh, int dw, int pt, int pl, int sh, int sw, float bias, float* dst,
                          int ho, int wo);

// The even and odd columns of the n floats at src into even[0, (n + 1) / 2) and odd[0, n / 2)
// (in AVX2 on x86-64: requires depthwise_avx2_supported() there).
void split_even_odd_columns(const float* src, int n, float* even, float* odd);

}  // namespace keyfleet::vision
