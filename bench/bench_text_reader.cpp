// Milliseconds per 640x480 keyframe for each text-reading engine: an ICDAR 2015 photo
// resized to keyframe size when the shared data is there, else a generated sign.
#include <benchmark/benchmark.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "keyfleet/station/text/text_reader.hpp"

namespace {

cv::Mat keyframe() {
  const char* env = std::getenv("KEYFLEET_DATA");
  const std::filesystem::path data = env ? env : "../shared/data";
  cv::Mat photo = cv::imread((data / "icdar2015/train_sharp/images/img_8.jpg").string());
  if (photo.empty()) {
    photo = cv::Mat(480, 640, CV_8UC3, cv::Scalar(150, 160, 170));
    cv::putText(photo, "GRAND HOTEL", {60, 250}, cv::FONT_HERSHEY_DUPLEX, 2.0,
                cv::Scalar(30, 20, 120), 4, cv::LINE_AA);
  }
  cv::Mat out;
  cv::resize(photo, out, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
  return out;
}

void read_keyframe(benchmark::State& state, const std::string& engine) {
  keyfleet::TextReadingConfig params;
  params.engine = engine;
  const auto reader = keyfleet::station::make_text_reader(params);
  const cv::Mat image = keyframe();
  std::size_t words = 0;
  for (auto _ : state) {
    const auto read = reader->read(image);
    words = read.size();
    benchmark::DoNotOptimize(words);
  }
  state.counters["words"] = double(words);
}

}  // namespace

BENCHMARK_CAPTURE(read_keyframe, tesseract, std::string("tesseract"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(10)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);
BENCHMARK_CAPTURE(read_keyframe, mininet_tesseract, std::string("mininet+tesseract"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(10)
    ->Repetitions(3)
    ->ReportAggregatesOnly(true);

BENCHMARK_MAIN();
