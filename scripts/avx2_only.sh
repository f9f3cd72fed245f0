# shellcheck shell=bash
# Sourced by the benchmark scripts for --avx2-only: OpenCV's AVX-512 dispatch turned off, the
# approximation of an AVX2-only CPU on a host with AVX-512 (docs/evaluation.md, "The CPU class of
# a figure"). keyfleet's bfloat16 products stay off by the configs' defaults.
OPENCV_CPU_DISABLE=AVX512F,AVX512-SKX,AVX512-ICL,AVX512-COMMON,AVX512BW,AVX512CD
export OPENCV_CPU_DISABLE=$OPENCV_CPU_DISABLE,AVX512DQ,AVX512VL
