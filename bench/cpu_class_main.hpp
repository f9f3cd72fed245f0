#pragma once
// The body of a benchmark program's main whose figures depend on the CPU class (AVX2, AVX-512,
// AVX512-BF16): every report carries a `cpu_class` line saying which, and a `keyfleet_kernels`
// line saying which of keyfleet's stand-in kernels run in float, in bfloat16 and in int8.
#include <benchmark/benchmark.h>

#include "keyfleet/vision/cpu_class.hpp"

namespace keyfleet::bench {

inline int run_benchmarks_with_cpu_class(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("cpu_class", vision::cpu_class_line());
  benchmark::AddCustomContext(
      "keyfleet_kernels", "in float: " + vision::segmenter_kernels(false) +
                              "; in bfloat16 where asked: " + vision::segmenter_kernels(true) +
                              "; with int8 where asked: " + vision::segmenter_kernels(false, true));
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace keyfleet::bench
