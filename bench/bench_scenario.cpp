// Scenario generation cost per stage and per frame (Google Benchmark; prints figures).
//   build/bin/bench_scenario [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/scenario/camera_effects.hpp"
#include "keyfleet/scenario/flight.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"

namespace {

using namespace keyfleet;
using namespace keyfleet::scenario;

ScenarioConfig bench_config() {
  ScenarioConfig config;  // procedural textures: the same on every machine
  config.street.length_m = 120;
  return config;
}

struct Fixture {
  ScenarioConfig config = bench_config();
  std::mt19937_64 rng{config.seed};
  StreetWorld world = build_street(config, rng);
  PlaneRenderer renderer{camera_model(config)};
  DayLighting lighting = day_lighting(world, 0, config.seed);
  Flight flight{config.drones, 0, config.seed, rng};
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void BM_BuildStreet(benchmark::State& state) {
  const ScenarioConfig config = bench_config();
  for (auto _ : state) {
    std::mt19937_64 rng(config.seed);
    benchmark::DoNotOptimize(build_street(config, rng));
  }
}
BENCHMARK(BM_BuildStreet)->Unit(benchmark::kMillisecond);

void BM_RenderFrame(benchmark::State& state) {
  Fixture& f = fixture();
  double t = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.renderer.render(f.world, f.flight.pose_at(t), f.lighting));
    t += 1 / 30.0;
  }
}
BENCHMARK(BM_RenderFrame)->Unit(benchmark::kMillisecond);

void BM_CameraEffects(benchmark::State& state) {
  Fixture& f = fixture();
  const RenderedView view = f.renderer.render(f.world, f.flight.pose_at(5), f.lighting);
  CameraEffects effects(f.config.camera, {f.config.width, f.config.height}, 30, 1);
  AppliedEffects applied;
  for (auto _ : state)
    benchmark::DoNotOptimize(effects.apply(view.radiance, double(state.range(0)), 10, applied));
}
BENCHMARK(BM_CameraEffects)->Arg(0)->Arg(8)->Unit(benchmark::kMillisecond);

void BM_WordsInView(benchmark::State& state) {
  Fixture& f = fixture();
  const CameraPose pose = f.flight.pose_at(5);
  const RenderedView view = f.renderer.render(f.world, pose, f.lighting);
  for (auto _ : state)
    benchmark::DoNotOptimize(words_in_view(f.world, f.renderer, pose, view.plane_id));
}
BENCHMARK(BM_WordsInView)->Unit(benchmark::kMillisecond);

// The whole thing, written to disk: frames per second of `keyfleet scenario generate`.
void BM_GenerateScenario(benchmark::State& state) {
  ScenarioConfig config = bench_config();
  config.frames_per_drone = 60;
  config.drones.count = 2;
  const auto out = std::filesystem::temp_directory_path() / "keyfleet_bench_scenario";
  std::uint64_t frames = 0;
  for (auto _ : state) {
    std::filesystem::remove_all(out);
    frames +=
        generate_scenario(config, out.string(), null_logger(), unsigned(state.range(0))).frames;
  }
  std::filesystem::remove_all(out);
  state.counters["frames_per_s"] = benchmark::Counter(double(frames), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_GenerateScenario)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  keyfleet::keep_image_buffers_in_heap();  // as the executables do
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
