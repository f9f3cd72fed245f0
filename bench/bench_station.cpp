// The station's analysis cost on generated street keyframes (640x480 JPEG): place
// recognition (ORB + bag of words + verification), text reading, both; and the keyframes per
// second the analysis pool sustains with 1 and 2 workers; at the station's defaults (text read
// by ppocr), and with tesseract for comparison. Prints figures; never pass/fail.
//   build/bin/bench_station [--benchmark_repetitions=3 --benchmark_report_aggregates_only=true]
#include <benchmark/benchmark.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <exception>
#include <filesystem>
#include <memory>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/station/analysis_pool.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/keyframe_analyzer.hpp"
#include "keyfleet/station/station_config.hpp"

namespace {

using namespace keyfleet;
using namespace keyfleet::station;

// Keyframes of a 3-drone flight, every 10th frame, as the agents would send them.
struct Keyframes {
  std::vector<AnalysisJob> jobs;
  Keyframes() {
    ScenarioConfig config;
    config.frames_per_drone = 200;
    config.street.length_m = 60;
    const auto dir = std::filesystem::temp_directory_path() / "keyfleet_bench_station";
    std::filesystem::remove_all(dir);
    scenario::generate_scenario(config, dir.string(), null_logger());
    const JpegCodec codec(90);
    for (const auto& drone : std::filesystem::directory_iterator(dir)) {
      if (!drone.is_directory()) continue;
      std::vector<std::filesystem::path> frames;
      for (const auto& f : std::filesystem::directory_iterator(drone.path() / "frames"))
        frames.push_back(f.path());
      std::sort(frames.begin(), frames.end());
      for (std::size_t i = 0; i < frames.size(); i += 10) {
        AnalysisJob job;
        job.key = {drone.path().filename().string(), i};
        job.capture_time_ns = static_cast<std::int64_t>(i) * 33'333'333;
        job.jpeg = codec.encode(cv::imread(frames[i].string(), cv::IMREAD_COLOR));
        jobs.push_back(std::move(job));
      }
    }
    std::filesystem::remove_all(dir);
  }
};

const Keyframes& keyframes() {
  static Keyframes k;
  return k;
}

// Decoding a stored keyframe (the station decodes it once, to check it, and analyses those
// pixels; a keyframe analysed after a restart is decoded again): arg 0 =
// the station's JpegCodec (libjpeg-turbo into BGR), 1 = cv::imdecode as it decoded until
// 2026-11-27. The same pixels (test JpegCodec.DecodesThePixelsOpenCvDecodes).
void BM_DecodeKeyframe(benchmark::State& state) {
  const JpegCodec codec(90);
  const auto& jobs = keyframes().jobs;
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& bytes = jobs[i++ % jobs.size()].jpeg;
    cv::Mat image =
        state.range(0) == 0 ? codec.decode(bytes).image : cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    benchmark::DoNotOptimize(image.data);
  }
}
BENCHMARK(BM_DecodeKeyframe)
    ->ArgNames({"codec0_imdecode1"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->Iterations(400);

// The station's defaults (configs/station.yaml: text engine ppocr, detector size auto, one
// OpenCV thread, places on) with text and places on or off and the text engine chosen.
constexpr const char* kEngines[] = {"ppocr", "tesseract"};

AnalysisConfig config_with(bool text, bool places, std::int64_t engine) {
  AnalysisConfig config;
  config.text.enabled = text;
  config.text.engine = kEngines[engine];
  config.places.enabled = places;
  return config;
}

// Per keyframe, one thread: arg 0 = places, 1 = text, 2 = both; arg 1 = text engine (0 ppocr,
// the default; 1 tesseract).
void BM_AnalyseKeyframe(benchmark::State& state) {
  const AnalysisConfig config =
      config_with(state.range(0) >= 1, state.range(0) != 1, state.range(1));
  auto places = make_configured_place_recognizer(config.places);
  std::unique_ptr<TextReader> reader;
  try {
    reader = make_configured_text_reader(config.text);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  KeyframeAnalyzer analyzer(std::move(reader), places.get(),
                            make_configured_place_describer(config.places), config, null_logger());
  const auto& jobs = keyframes().jobs;
  std::size_t i = 0, words = 0;
  for (auto _ : state) {
    const AnalysisResult r = analyzer.analyse(jobs[i++ % jobs.size()]);
    words += r.words.size();
  }
  state.counters["words_per_keyframe"] =
      benchmark::Counter(double(words) / double(state.iterations()));
}
BENCHMARK(BM_AnalyseKeyframe)
    ->ArgNames({"places0_text1_both2", "ppocr0_tesseract1"})
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(40);

// The place step a keyframe, one part at a time, one thread: arg 0 = grey conversion and ORB
// (the station's 1000 features), 1 = the CNN descriptor (PlaceNet), 2 = retrieval, verification
// and adding to the database (which grows over the flight's keyframes, then starts again).
void BM_PlaceSteps(benchmark::State& state) {
  const AnalysisConfig config = config_with(false, true, 0);
  auto describer = make_configured_place_describer(config.places);
  OrbParams orb;
  orb.features = config.places.orb_features;
  const JpegCodec codec(90);
  std::vector<cv::Mat> images;
  for (const auto& job : keyframes().jobs) images.push_back(codec.decode(job.jpeg).image);
  std::vector<PlaceView> views;
  if (state.range(0) == 2) {
    for (const cv::Mat& image : images) {
      cv::Mat grey;
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
      views.push_back(
          {extract_orb(grey, orb), describer ? describer->describe(image) : std::vector<float>{}});
    }
  }
  const auto& jobs = keyframes().jobs;
  auto places = make_configured_place_recognizer(config.places);
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i++ % images.size();
    if (state.range(0) == 0) {
      cv::Mat grey;
      cv::cvtColor(images[k], grey, cv::COLOR_BGR2GRAY);
      benchmark::DoNotOptimize(extract_orb(grey, orb).keypoints.size());
    } else if (state.range(0) == 1) {
      benchmark::DoNotOptimize(describer->describe(images[k]).size());
    } else {
      if (k == 0) {
        state.PauseTiming();
        places = make_configured_place_recognizer(config.places);
        state.ResumeTiming();
      }
      const KeyframeKey& key = jobs[k].key;
      const auto outcome =
          places->recognise_then_add(key, jobs[k].capture_time_ns, views[k],
                                     not_a_recent_neighbour(key, jobs[k].capture_time_ns,
                                                            config.places.same_robot_exclusion_s));
      benchmark::DoNotOptimize(outcome.checked.size());
    }
  }
}
BENCHMARK(BM_PlaceSteps)
    ->ArgNames({"orb0_descriptor1_recognise2"})
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(60);

// The whole flight through the pool with everything on (the station's defaults): keyframes per
// second sustained with 1 (the default) and 2 workers, reading with ppocr or tesseract.
void BM_StationThroughput(benchmark::State& state) {
  const AnalysisConfig config = config_with(true, true, state.range(1));
  const auto& jobs = keyframes().jobs;
  try {
    make_configured_text_reader(config.text);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  for (auto _ : state) {
    auto places = make_configured_place_recognizer(config.places);
    std::vector<AnalysisPool::Step> steps;
    for (int w = 0; w < state.range(0); ++w) {
      auto analyzer = std::make_shared<KeyframeAnalyzer>(
          make_configured_text_reader(config.text), places.get(),
          make_configured_place_describer(config.places), config, null_logger());
      steps.push_back([analyzer](const AnalysisJob& job) { return analyzer->analyse(job); });
    }
    AnalysisPool pool(std::move(steps), jobs.size(), null_logger());
    for (const auto& job : jobs) pool.submit(job);
    pool.wait_until_idle(std::chrono::hours(1));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * jobs.size()));
}
BENCHMARK(BM_StationThroughput)
    ->ArgNames({"workers", "ppocr0_tesseract1"})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

int main(int argc, char** argv) {
  keyfleet::limit_openmp_to_one_thread(argv);
  keep_image_buffers_in_heap();
  benchmark::Initialize(&argc, argv);
  keyframes();  // generate before timing
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
