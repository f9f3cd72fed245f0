// The agent's per-frame selection cost on 640x480 frames, stage by stage, like Alonso et
// al.'s (ICRA 2019) breakdown (resize, blur, brightness, sharpness, trigger, semantic), and
// amortised over a generated flight. The quality stages run both as they were before the fused
// implementation and as they are now, and a table at the end puts them side by side with
// the per-frame total (the goal: under 1 ms on one core). Prints figures; never
// pass/fail.
//   build/bin/bench_selection [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
//   build/bin/bench_selection --benchmark_filter=quality/ --benchmark_repetitions=9
//   build/bin/bench_selection --benchmark_filter=DecodeFrame --benchmark_repetitions=9
#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <iomanip>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "keyfleet/agent/image_quality.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/agent/keyframe_trigger.hpp"
#include "keyfleet/agent/klt_trigger.hpp"
#include "keyfleet/common/jpeg_turbo.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/eval/image_quality_reference.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
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

// --- quality + sharpness, before and after --------------------------------------------------

// The per-frame scoring as it was before the fused implementation (OpenCV operations on float
// images, image_quality_reference.hpp, fresh temporaries every frame): the baseline.
namespace before {

using eval::reference::brightness_score;
using eval::reference::energy_of_laplacian;
using eval::reference::kumar_sharpness;

struct Images {
  cv::Mat work, small, grey, work_grey;
  void prepare(const cv::Mat& bgr, int size, int width) {
    const double f = std::min(1.0, double(width) / bgr.cols);
    work = f < 1 ? cv::Mat() : bgr;
    if (f < 1) cv::resize(bgr, work, {}, f, f, cv::INTER_AREA);
    cv::resize(work, small, {size, size}, 0, 0, cv::INTER_AREA);
    cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
    cv::cvtColor(work, work_grey, cv::COLOR_BGR2GRAY);
  }
};

}  // namespace before

// What the selector does per frame before the semantic stage, in either implementation.
struct Scoring {
  virtual ~Scoring() = default;
  virtual void prepare(const cv::Mat& bgr) = 0;
  virtual double blur() = 0;
  virtual double brightness() = 0;
  virtual double sharpness() = 0;
};

const QualityConfig kQuality;
const agent::SharpnessParams kSharpness{kQuality.edge_contrast, kQuality.sharp_ratio};

struct BeforeScoring final : Scoring {
  before::Images images;
  void prepare(const cv::Mat& bgr) override {
    images = {};  // fresh temporaries every frame, as the selector had them
    images.prepare(bgr, kQuality.size, kQuality.sharpness_width);
  }
  double blur() override { return before::energy_of_laplacian(images.grey); }
  double brightness() override { return before::brightness_score(images.small); }
  double sharpness() override { return before::kumar_sharpness(images.work_grey, kSharpness); }
};

struct AfterScoring final : Scoring {
  agent::QualityImages images;
  void prepare(const cv::Mat& bgr) override {
    images.prepare(bgr, kQuality.size, kQuality.sharpness_width);
  }
  double blur() override { return agent::energy_of_laplacian(images.grey); }
  double brightness() override { return agent::brightness_score(images.small); }
  double sharpness() override {
    return agent::kumar_sharpness(images.work_grey, kSharpness, images.sharpness);
  }
};

std::unique_ptr<Scoring> make_scoring(bool after) {
  if (after) return std::make_unique<AfterScoring>();
  return std::make_unique<BeforeScoring>();
}

enum class Stage { kResize, kBlur, kBrightness, kSharpness, kTotal };
constexpr const char* kStageNames[] = {"resize", "blur", "brightness", "sharpness", "total"};

// One stage on one frame. Not inlined, so that instruction counts can be taken for it alone:
//   valgrind --tool=callgrind --toggle-collect='*run_stage*' bench_selection
//       --benchmark_filter=quality/total --benchmark_min_time=0.01
// and callgrind_annotate --inclusive=yes: its Ir over its calls is the count per frame.
[[gnu::noinline]] double run_stage(Scoring& s, Stage stage, const cv::Mat& bgr) {
  switch (stage) {
    case Stage::kResize: s.prepare(bgr); return 0;
    case Stage::kBlur: return s.blur();
    case Stage::kBrightness: return s.brightness();
    case Stage::kSharpness: return s.sharpness();
    case Stage::kTotal: s.prepare(bgr); return s.blur() + s.brightness() + s.sharpness();
  }
  return 0;
}

// One stage over the flight's frames (the later stages on images prepared beforehand, so
// that only the stage is timed), or the whole per-frame scoring for kTotal.
void BM_Quality(benchmark::State& state, Stage stage, bool after) {
  const std::size_t n = flight().frames.size();
  std::vector<std::unique_ptr<Scoring>> prepared;
  if (stage != Stage::kResize && stage != Stage::kTotal)
    for (std::size_t i = 0; i < n; ++i) {
      prepared.push_back(make_scoring(after));
      prepared.back()->prepare(frame(i));
    }
  auto scoring = make_scoring(after);
  // Warm up outside the timed loop: OpenCV builds its Lab tables on the first conversion.
  scoring->prepare(frame(0));
  benchmark::DoNotOptimize(scoring->blur() + scoring->brightness() + scoring->sharpness());
  std::size_t i = 0;
  for (auto _ : state) {
    Scoring& s = prepared.empty() ? *scoring : *prepared[i % n];
    benchmark::DoNotOptimize(run_stage(s, stage, frame(i)));
    ++i;
  }
}

// The same through HierarchicalSelector::score, which also runs the stage clocks.
void BM_SelectorScore(benchmark::State& state) {
  SelectorConfig config;
  config.strategy = SelectorConfig::Strategy::kQuality;
  config.trigger.kind = TriggerConfig::Kind::kStride;
  agent::HierarchicalSelector selector(config, std::make_unique<agent::StrideTrigger>(30), nullptr,
                                       nullptr);
  std::size_t i = 0;
  for (auto _ : state)
    benchmark::DoNotOptimize(selector.score(flight().frames[i++ % flight().frames.size()]));
}

void register_quality_benchmarks() {
  for (Stage stage :
       {Stage::kResize, Stage::kBlur, Stage::kBrightness, Stage::kSharpness, Stage::kTotal})
    for (bool after : {false, true})
      benchmark::RegisterBenchmark(
          (std::string("quality/") + kStageNames[int(stage)] + (after ? "/after" : "/before"))
              .c_str(),
          BM_Quality, stage, after)
          ->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("quality/total/selector_score", BM_SelectorScore)
      ->Unit(benchmark::kMicrosecond);
}

// Prints the console output as usual, then the quality stages side by side: CPU time per
// frame, the median when repetitions ran, otherwise the single run.
class QualitySummary : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& run : runs) {
      const std::string name = run.run_name.function_name;
      if (name.rfind("quality/", 0) != 0 || run.error_occurred) continue;
      const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
      if (run.run_type == Run::RT_Aggregate && !median) continue;
      if (run.run_type == Run::RT_Iteration && run.repetitions > 1) continue;
      cpu_us_[name] = run.GetAdjustedCPUTime();  // microseconds (the unit registered)
      summary_of_ = median ? "median of the repetitions" : "one run; add --benchmark_repetitions";
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    if (cpu_us_.empty()) return;
    auto& out = GetOutputStream();
    out << "\nquality + sharpness per 640x480 frame, one core, CPU ms (" << summary_of_ << ")\n";
    out << "stage         before     after     ratio\n";
    double before_sum = 0, after_sum = 0;
    for (const char* stage : kStageNames) {
      const auto b = cpu_us_.find(std::string("quality/") + stage + "/before");
      const auto a = cpu_us_.find(std::string("quality/") + stage + "/after");
      if (b == cpu_us_.end() || a == cpu_us_.end()) continue;
      if (std::string(stage) != "total") {
        before_sum += b->second;
        after_sum += a->second;
      }
      print(out, stage, b->second, a->second);
    }
    if (before_sum > 0) print(out, "sum of stages", before_sum, after_sum);
    const auto selector = cpu_us_.find("quality/total/selector_score");
    if (selector != cpu_us_.end())
      out << "HierarchicalSelector::score (with its stage clocks): " << std::fixed
          << std::setprecision(3) << selector->second / 1000 << " ms per frame\n";
  }

 private:
  static void print(std::ostream& out, const std::string& stage, double before_us,
                    double after_us) {
    out << std::left << std::setw(12) << stage << std::right << std::fixed << std::setprecision(3)
        << std::setw(8) << before_us / 1000 << std::setw(10) << after_us / 1000 << std::setw(9)
        << std::setprecision(1) << before_us / after_us << "x\n";
  }
  std::map<std::string, double> cpu_us_;
  std::string summary_of_;
};

void BM_OrbSlamTrigger(benchmark::State& state) {  // arg: image scale in percent
  agent::OrbSlamTriggerParams params;
  params.image_scale = double(state.range(0)) / 100;
  agent::OrbSlamTrigger trigger(params);
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(trigger.is_keyframe(flight().frames[i++ % 150]));
}
BENCHMARK(BM_OrbSlamTrigger)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);

void BM_KltTrigger(benchmark::State& state) {  // arg: image scale in percent
  agent::KltTriggerParams params;
  params.image_scale = double(state.range(0)) / 100;
  agent::KltSlamTrigger trigger(params);
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(trigger.is_keyframe(flight().frames[i++ % 150]));
}
BENCHMARK(BM_KltTrigger)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);

// --- the replay source's decoding ------------------------------------------------------------

// The flight's frames as the scenario stores them (JPEG, quality 92).
const std::vector<std::vector<std::uint8_t>>& flight_jpegs() {
  static const auto jpegs = [] {
    std::vector<std::vector<std::uint8_t>> out(flight().frames.size());
    for (std::size_t i = 0; i < out.size(); ++i)
      cv::imencode(".jpg", flight().frames[i].image, out[i], {cv::IMWRITE_JPEG_QUALITY, 92});
    return out;
  }();
  return jpegs;
}

// One 640x480 frame from its JPEG into a new BGR image, as the source hands it on: arg 0 =
// cv::imdecode (what cv::imread did before), 1 = decode_jpeg_bgr (libjpeg-turbo, BGR out).
void BM_DecodeFrame(benchmark::State& state) {
  const auto& jpegs = flight_jpegs();
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& bytes = jpegs[i++ % jpegs.size()];
    cv::Mat image;
    if (state.range(0) == 0)
      image = cv::imdecode(bytes, cv::IMREAD_COLOR);
    else
      keyfleet::decode_jpeg_bgr(bytes.data(), bytes.size(), image);
    benchmark::DoNotOptimize(image.data);
  }
}
BENCHMARK(BM_DecodeFrame)->ArgName("turbo")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// selector.decode_reduce: decode_jpeg_bgr at 1/N (libjpeg's DCT scaling) of the same frames. The
// entropy decoding is the same work at every N; only the inverse DCT, upsampling and colour
// conversion shrink.
void BM_DecodeFrameReduced(benchmark::State& state) {
  const auto& jpegs = flight_jpegs();
  const int reduce = int(state.range(0));
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& bytes = jpegs[i++ % jpegs.size()];
    cv::Mat image;
    keyfleet::decode_jpeg_bgr(bytes.data(), bytes.size(), image, reduce);
    benchmark::DoNotOptimize(image.data);
  }
}
BENCHMARK(BM_DecodeFrameReduced)
    ->ArgName("reduce")
    ->Arg(1)
    ->Arg(2)
    ->Arg(4)
    ->Unit(benchmark::kMillisecond);

// The whole selection, amortised per frame over the flight: strategy quality, or full with the
// shipped MiniNet at its configured input size (one thread); trigger 0 = a stride (no cost, the
// others' cost is the difference), 1 = orbslam, 2 = klt (on the quality stage's grey image).
void BM_SelectionPerFrame(benchmark::State& state) {
  SelectorConfig config;
  const TriggerConfig::Kind kinds[] = {TriggerConfig::Kind::kStride, TriggerConfig::Kind::kOrbSlam,
                                       TriggerConfig::Kind::kKlt};
  config.trigger.kind = kinds[state.range(0)];
  config.strategy =
      state.range(1) ? SelectorConfig::Strategy::kFull : SelectorConfig::Strategy::kQuality;
  std::size_t frames = 0;
  for (auto _ : state) {
    auto selector = agent::make_selector(config, 30);
    for (const auto& f : flight().frames) benchmark::DoNotOptimize(selector->push(f));
    benchmark::DoNotOptimize(selector->finish());
    frames += flight().frames.size();
  }
  // Seconds of CPU per frame (printed with an SI prefix: 2m = 2 ms).
  state.counters["per_frame"] =
      benchmark::Counter(double(frames), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SelectionPerFrame)
    ->ArgNames({"trigger", "full"})
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

}  // namespace

int main(int argc, char** argv) {
  keyfleet::keep_image_buffers_in_heap();
  cv::setNumThreads(1);  // one core, as the targets are stated
  flight();              // generate the frames before any timing
  register_quality_benchmarks();
  benchmark::Initialize(&argc, argv);
  QualitySummary reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
}
