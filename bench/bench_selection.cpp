// The agent's per-frame selection cost on 640x480 frames, stage by stage, like the first
// seed's breakdown (resize, blur, brightness, sharpness, trigger, semantic), and amortised
// over a generated flight. Prints figures; never pass/fail.
//   build/bin/bench_selection [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
#include <benchmark/benchmark.h>
#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <random>

#include "keyfleet/agent/image_quality.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/agent/keyframe_trigger.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"

namespace {

using namespace keyfleet;

// A generated flight shared by every benchmark: 640x480 street frames with text.
struct Flight {
  std::vector<agent::Frame> frames;
  Flight() {
    ScenarioConfig config;
    config.frames_per_drone = 150;
    config.drones.count = 1;
    config.street.length_m = 60;
    const auto dir = std::filesystem::temp_directory_path() / "keyfleet_bench_selection";
    std::filesystem::remove_all(dir);
    scenario::generate_scenario(config, dir.string(), null_logger());
    SourceConfig source;
    source.kind = SourceConfig::Kind::kScenario;
    source.path = dir.string();
    source.drone = "drone_0";
    auto reader = agent::make_frame_source(source, null_logger());
    while (auto frame = reader->next()) frames.push_back(*frame);
    std::filesystem::remove_all(dir);
  }
};

const Flight& flight() {
  static Flight f;
  return f;
}

const cv::Mat& frame(std::size_t i) { return flight().frames[i % flight().frames.size()].image; }

void BM_Resize112(benchmark::State& state) {
  cv::Mat small;
  std::size_t i = 0;
  for (auto _ : state) cv::resize(frame(i++), small, {112, 112}, 0, 0, cv::INTER_AREA);
}
BENCHMARK(BM_Resize112)->Unit(benchmark::kMicrosecond);

void BM_BlurEnergy112(benchmark::State& state) {
  cv::Mat small, grey;
  cv::resize(frame(0), small, {112, 112}, 0, 0, cv::INTER_AREA);
  cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
  for (auto _ : state) benchmark::DoNotOptimize(agent::energy_of_laplacian(grey));
}
BENCHMARK(BM_BlurEnergy112)->Unit(benchmark::kMicrosecond);

void BM_Brightness112(benchmark::State& state) {
  cv::Mat small;
  cv::resize(frame(0), small, {112, 112}, 0, 0, cv::INTER_AREA);
  for (auto _ : state) benchmark::DoNotOptimize(agent::brightness_score(small));
}
BENCHMARK(BM_Brightness112)->Unit(benchmark::kMicrosecond);

void BM_Sharpness(benchmark::State& state) {  // arg: working width
  cv::Mat grey;
  cv::cvtColor(frame(0), grey, cv::COLOR_BGR2GRAY);
  const double f = double(state.range(0)) / grey.cols;
  if (f < 1) cv::resize(grey, grey, {}, f, f, cv::INTER_AREA);
  for (auto _ : state) benchmark::DoNotOptimize(agent::kumar_sharpness(grey));
}
BENCHMARK(BM_Sharpness)->Arg(320)->Arg(640)->Unit(benchmark::kMicrosecond);

void BM_OrbSlamTrigger(benchmark::State& state) {  // arg: image scale in percent
  agent::OrbSlamTriggerParams params;
  params.image_scale = double(state.range(0)) / 100;
  agent::OrbSlamTrigger trigger(params);
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(trigger.is_keyframe(flight().frames[i++ % 150]));
}
BENCHMARK(BM_OrbSlamTrigger)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);

// The whole selection, amortised per frame over the flight: strategy quality (no model
// until MiniNet ships), ORB-SLAM trigger included or replaced by a stride.
void BM_SelectionPerFrame(benchmark::State& state) {
  SelectorConfig config;
  config.strategy = SelectorConfig::Strategy::kQuality;
  config.trigger.kind =
      state.range(0) ? TriggerConfig::Kind::kOrbSlam : TriggerConfig::Kind::kStride;
  std::size_t frames = 0;
  for (auto _ : state) {
    auto selector = agent::make_selector(config, 30);
    for (const auto& f : flight().frames) benchmark::DoNotOptimize(selector->push(f));
    frames += flight().frames.size();
  }
  // Seconds of CPU per frame (printed with an SI prefix: 2m = 2 ms).
  state.counters["per_frame"] =
      benchmark::Counter(double(frames), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SelectionPerFrame)
    ->ArgName("orbslam_trigger")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

}  // namespace

int main(int argc, char** argv) {
  keyfleet::keep_image_buffers_in_heap();
  cv::setNumThreads(1);  // one core, as the targets are stated
  flight();              // generate the frames before any timing
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
