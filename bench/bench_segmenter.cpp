// The text segmenter's forward pass (blob, network, argmax) on one frame, per choice of
// layers (OpenCV's, the vectorised SELU, SELU + depthwise, all stand-ins in float, all stand-ins
// in bfloat16 where the CPU has it: the default), thread
// count and input size. Prints figures; never pass/fail.
//   build/bin/bench_segmenter [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
// KEYFLEET_SEGMENTER_MODEL=path.onnx times another export (default: the shipped MiniNet).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <string>

#include "cpu_class_main.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "keyfleet/vision/text_segmenter.hpp"

namespace {

using namespace keyfleet;

std::string model() {
  const char* env = std::getenv("KEYFLEET_SEGMENTER_MODEL");
  return vision::locate_model(env && *env ? env : "mininet_text.onnx", "segmenter model");
}

// Args: layers (0 = OpenCV's, 1 = vectorised SELU, 2 = SELU + depthwise, 3 = all in float,
// 4 = all in bfloat16), threads, input height (width 512).
void BM_Segment(benchmark::State& state) {
  if (state.range(0) == 4 && !vision::bfloat16_products_supported()) {
    state.SkipWithError("this CPU has no AVX512-BF16");
    return;
  }
  // From OpenCV's own layers up, as the labels say (a brace list of the first few flags left the
  // others at their defaults, every other stand-in on, even in "OpenCV layers").
  const int level = int(state.range(0));
  vision::DnnLayers layers =
      level >= 3 ? vision::DnnLayers::in_float() : vision::DnnLayers::opencv();
  layers.vectorised_selu = level >= 1;
  layers.depthwise = level >= 2;
  layers.bfloat16_products = level >= 4;
  const int threads = int(state.range(1));
  const cv::Size size(512, int(state.range(2)));
  vision::DnnTextSegmenter net(model(), threads, size, layers);
  const cv::Mat frame(size, CV_8UC3, cv::Scalar(90, 120, 150));
  net.segment({frame});  // warm-up
  for (auto _ : state) benchmark::DoNotOptimize(net.segment({frame}));
  const char* names[] = {"OpenCV layers", "vectorised SELU", "SELU + depthwise",
                         "all stand-ins, float", "all stand-ins, bfloat16"};
  state.SetLabel(std::string(names[state.range(0)]) + ", " + std::to_string(threads) +
                 " thread(s), 512x" + std::to_string(size.height));
}
BENCHMARK(BM_Segment)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {1, 2}, {256, 384}})
    ->ArgNames({"layers", "threads", "height"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

}  // namespace

int main(int argc, char** argv) {
  return keyfleet::bench::run_benchmarks_with_cpu_class(argc, argv);
}
