// The text segmenter's forward pass (blob, network, argmax) on one frame, per SELU
// implementation, thread count and input size. Prints figures; never pass/fail.
//   build/bin/bench_segmenter [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
// KEYFLEET_SEGMENTER_MODEL=path.onnx times another export (default: the shipped MiniNet).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <string>

#include "keyfleet/agent/text_segmenter.hpp"

namespace {

using namespace keyfleet;

std::string model() {
  const char* env = std::getenv("KEYFLEET_SEGMENTER_MODEL");
  return agent::locate_model(env && *env ? env : "mininet_text.onnx");
}

// Args: SELU (0 = OpenCV's, 1 = vectorised), threads, input height (width 512).
void BM_Segment(benchmark::State& state) {
  const auto selu = state.range(0) ? agent::DnnSelu::kVectorised : agent::DnnSelu::kOpenCv;
  const int threads = int(state.range(1));
  const cv::Size size(512, int(state.range(2)));
  agent::DnnTextSegmenter net(model(), threads, size, selu);
  const cv::Mat frame(size, CV_8UC3, cv::Scalar(90, 120, 150));
  net.segment({frame});  // warm-up
  for (auto _ : state) benchmark::DoNotOptimize(net.segment({frame}));
  state.SetLabel(std::string(selu == agent::DnnSelu::kVectorised ? "vectorised" : "opencv") +
                 " selu, " + std::to_string(threads) + " thread(s), 512x" +
                 std::to_string(size.height));
}
BENCHMARK(BM_Segment)
    ->ArgsProduct({{0, 1}, {1, 2}, {256, 384}})
    ->ArgNames({"selu", "threads", "height"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

}  // namespace

BENCHMARK_MAIN();
