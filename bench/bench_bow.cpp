// Place-retrieval costs on 640x480 generated street frames: ORB extraction, BoW transform
// (k=10, L=4 vocabulary built from the same flight) and inverted-index queries against
// databases of 100 to 10,000 keyframes, on one core. Prints figures; never pass/fail.
//   build/bin/bench_bow --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <filesystem>
#include <random>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/station/places/bow_database.hpp"
#include "keyfleet/station/places/orb_extractor.hpp"
#include "keyfleet/station/places/orb_vocabulary.hpp"

namespace {

namespace fs = std::filesystem;
using namespace keyfleet;

// Two drones' frames of one generated street, their ORB features and BoW vectors; drone_0's
// vectors fill the databases, drone_1's are the queries.
struct Flight {
  std::vector<cv::Mat> frames;
  std::vector<cv::Mat> descriptors;
  station::OrbVocabulary vocabulary;
  std::vector<station::BowVector> stored, queries;
  std::vector<station::FeatureVector> stored_direct;

  Flight() {
    cv::setNumThreads(1);  // one-core figures: OpenCV threads would hide CPU from the timer
    ScenarioConfig config;
    config.seed = 11;
    config.frames_per_drone = 120;
    config.drones.count = 2;
    const auto dir = fs::temp_directory_path() / "keyfleet_bench_bow";
    fs::remove_all(dir);
    scenario::generate_scenario(config, dir.string(), null_logger());
    std::vector<fs::path> paths;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.path().extension() == ".jpg" && e.path().parent_path().filename() == "frames")
        paths.push_back(e.path());
    std::sort(paths.begin(), paths.end());
    for (const auto& p : paths) {
      frames.push_back(cv::imread(p.string()));
      descriptors.push_back(station::extract_orb(frames.back(), station::OrbParams{}).descriptors);
    }
    fs::remove_all(dir);
    station::VocabularyParams params;
    params.seed = 3;
    vocabulary = station::OrbVocabulary::build(descriptors, params);
    const std::size_t half = frames.size() / 2;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      station::FeatureVector direct;
      auto bow = vocabulary.transform(descriptors[i], &direct);
      if (i < half) {
        stored.push_back(std::move(bow));
        stored_direct.push_back(std::move(direct));
      } else {
        queries.push_back(std::move(bow));
      }
    }
  }
};

const Flight& flight() {
  static Flight f;
  return f;
}

// A stored vector with a fifth of its words moved to random words and weights jittered:
// more keyframes with the statistics of real ones.
station::BowVector perturbed(const station::BowVector& v, std::mt19937& rng, std::size_t words) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<std::uint32_t> word(0, std::uint32_t(words - 1));
  std::vector<station::BowEntry> out;
  for (auto e : v) {
    if (unit(rng) < 0.2) e.word = word(rng);
    e.weight *= 0.5 + unit(rng);
    out.push_back(e);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.word < b.word; });
  station::BowVector merged;
  double total = 0;
  for (const auto& e : out) {
    if (!merged.empty() && merged.back().word == e.word)
      merged.back().weight += e.weight;
    else
      merged.push_back(e);
    total += e.weight;
  }
  for (auto& e : merged) e.weight /= total;
  return merged;
}

void BM_OrbExtract640(benchmark::State& state) {
  flight();  // the scenario and vocabulary are made once, outside the timing
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& f = flight().frames[i++ % flight().frames.size()];
    benchmark::DoNotOptimize(station::extract_orb(f, station::OrbParams{}));
  }
}
BENCHMARK(BM_OrbExtract640)->Unit(benchmark::kMillisecond);

void BM_Transform(benchmark::State& state) {
  flight();
  std::size_t i = 0;
  station::FeatureVector direct;
  for (auto _ : state) {
    const auto& d = flight().descriptors[i++ % flight().descriptors.size()];
    benchmark::DoNotOptimize(flight().vocabulary.transform(d, &direct));
  }
  state.counters["words"] = double(flight().vocabulary.word_count());
}
BENCHMARK(BM_Transform)->Unit(benchmark::kMillisecond);

void BM_Query(benchmark::State& state) {  // arg: database size
  const auto& f = flight();
  station::BowDatabase db;
  std::mt19937 rng(5);
  const std::size_t size = std::size_t(state.range(0));
  for (std::size_t j = 0; j < size; ++j) {
    const std::size_t source = j % f.stored.size();
    db.add(j < f.stored.size() ? f.stored[source]
                               : perturbed(f.stored[source], rng, f.vocabulary.word_count()),
           f.stored_direct[source]);
  }
  std::size_t i = 0;
  for (auto _ : state) {
    const auto matches = db.query(f.queries[i++ % f.queries.size()], 4);
    benchmark::DoNotOptimize(matches);
  }
  state.counters["entries"] = double(db.size());
}
BENCHMARK(BM_Query)->Arg(100)->Arg(1000)->Arg(5000)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
