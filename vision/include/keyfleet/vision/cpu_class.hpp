#pragma once
// The CPU class a figure was taken on, for benchmark output: what this CPU offers the inference
// kernels, what OpenCV's dispatch may use (OPENCV_CPU_DISABLE turns its AVX-512 paths off to
// approximate an AVX2-only CPU), and which of keyfleet's own kernels the semantic model runs.
// Robots and most laptops have AVX2 and FMA but no AVX-512.
#include <string>

namespace keyfleet::vision {

// "CPU: <model> (N threads); AVX2+FMA yes, AVX-512F yes, AVX512-BF16 yes; OpenCV may use:
// AVX2 FMA3 AVX512_SKX ... [OPENCV_CPU_DISABLE=...]"
std::string cpu_class_line();

// The segmenter's kernels: "bfloat16 products (AVX512-BF16), depthwise in AVX2", "float
// products, Winograd 3x3, depthwise in AVX2 (AVX2+FMA)" or "OpenCV's layers", with ", wide 1x1
// in int8 (AVX2)" (or AVX-VNNI, AVX512-VNNI: what the int8 products use here) where asked, for a
// semantic config that asks for bfloat16 and int8 or not.
std::string segmenter_kernels(bool bfloat16_wanted, bool int8_wanted = false);

}  // namespace keyfleet::vision
