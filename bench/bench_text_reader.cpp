// What reading text costs, in milliseconds (real time; medians of the repetitions):
//  - read_keyframe: a whole read of a 640x480 keyframe by each engine (an ICDAR 2015 photo
//    resized to keyframe size when the shared data is there, else a generated sign);
//  - the PP-OCR parts at 1 and 2 OpenCV threads: the detector (whole detect(), its network pass
//    alone, its DB post-processing alone) at each fetched input size on a real photo at its
//    native 1280x720 and resized to 640x480; the recogniser per input width on a real word crop;
//    the recogniser's work around its network (perspective cut, CTC decoding). The whole read
//    with the station's default (the wide 1x1 convolutions in int8, analysis.text.ppocr_int8)
//    and in float (ppocr_float); the recogniser in both (int8:1 and int8:0). Where a pass of the
//    detector at 640x480 and of the recogniser at width 160 spends its time, by layer type
//    (BM_PpocrLayerTypes: counters in ms; with KEYFLEET_LAYERS=1 in the environment each layer of
//    its last pass too, with its input and output shapes).
// Cases whose models (scripts/fetch_ppocr.sh) or data (KEYFLEET_DATA) are missing are skipped
// with the reason. Prints figures; never pass/fail.
// The recogniser's crops of one keyframe are read one at a time: OpenCV 4.6 cannot batch them.
// A [N,3,48,W] blob through a converted [1,3,48,W] file fails in its first Transpose (the
// Reshape targets hold batch 1: "permute_layer.cpp:161 (int)_numAxes == inputs[0].size()"), and
// a file converted for a fixed [N,3,48,W] fails in the first LayerNorm's Sub of [N,20,120] and
// [N,20,1] ("shape_utils.hpp:170 ... in function 'total'"). Its time is about linear in the
// width (BM_PpocrRecognize), so little is fixed per call that a batch could share anyway.
//   KEYFLEET_DATA=../shared/data build/bin/bench_text_reader
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cpu_class_main.hpp"
#include "keyfleet/common/process_tuning.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/vision/dnn_layers.hpp"
#include "keyfleet/vision/model_files.hpp"
#include "ppocr_detector.hpp"
#include "ppocr_recognizer.hpp"

namespace {

using keyfleet::station::PpocrDetector;
using keyfleet::station::PpocrRecognizer;
using keyfleet::station::TextQuad;

std::filesystem::path data_dir() {
  const char* env = std::getenv("KEYFLEET_DATA");
  return env ? env : "../shared/data";
}

// The ICDAR 2015 photo the cases read (1280x720), empty when the data is absent.
cv::Mat photo() {
  return cv::imread((data_dir() / "icdar2015/train_sharp/images/img_8.jpg").string());
}

cv::Mat keyframe() {
  cv::Mat image = photo();
  if (image.empty()) {
    image = cv::Mat(480, 640, CV_8UC3, cv::Scalar(150, 160, 170));
    cv::putText(image, "GRAND HOTEL", {60, 250}, cv::FONT_HERSHEY_DUPLEX, 2.0,
                cv::Scalar(30, 20, 120), 4, cv::LINE_AA);
  }
  cv::Mat out;
  cv::resize(image, out, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
  return out;
}

// A converted ppocr file, found as the reader finds it; nullopt (and the reason) when absent.
std::optional<std::string> ppocr_file(const std::string& file, std::string& why) {
  try {
    return keyfleet::vision::locate_model("ppocr/" + file, "ppocr model");
  } catch (const std::exception& e) {
    why = std::string(e.what()) + " (scripts/fetch_ppocr.sh converts the ppocr models)";
    return std::nullopt;
  }
}

void read_keyframe(benchmark::State& state, const std::string& engine, bool int8 = true) {
  keyfleet::TextReadingConfig params;
  params.engine = engine;
  params.ppocr.int8 = int8;
  std::unique_ptr<keyfleet::station::TextReader> reader;
  try {
    reader = keyfleet::station::make_text_reader(params);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  cv::setNumThreads(1);  // the station's default (TextReadingConfig::threads)
  const cv::Mat image = keyframe();
  std::size_t words = 0;
  for (auto _ : state) {
    const auto read = reader->read(image);
    words = read.size();
    benchmark::DoNotOptimize(words);
  }
  state.counters["words"] = double(words);
}

// Detector cases: arg 0 = input size (0: 640x480, 1: 1280x736), arg 1 = the photo at its native
// 1280x720 (0) or resized to 640x480 (1), arg 2 = OpenCV threads.
constexpr const char* kDetectorSizes[] = {"640x480", "1280x736"};
const cv::Size kDetectorInputs[] = {{640, 480}, {1280, 736}};

struct DetectorCase {
  std::unique_ptr<PpocrDetector> detector;
  cv::Mat image;
  std::string model;
};

std::optional<DetectorCase> detector_case(benchmark::State& state) {
  const auto size = std::size_t(state.range(0));
  std::string why;
  const auto model = ppocr_file(std::string("ppocr_det_") + kDetectorSizes[size] + ".onnx", why);
  if (!model) {
    state.SkipWithError(why.c_str());
    return std::nullopt;
  }
  DetectorCase c;
  c.model = *model;
  c.image = photo();
  if (c.image.empty()) {
    state.SkipWithError(
        "no ICDAR 2015 photo (icdar2015/train_sharp/images/img_8.jpg under "
        "KEYFLEET_DATA)");
    return std::nullopt;
  }
  if (state.range(1) == 1) cv::resize(c.image, c.image, {640, 480}, 0, 0, cv::INTER_AREA);
  c.detector = std::make_unique<PpocrDetector>(c.model, kDetectorInputs[size],
                                               keyfleet::station::DbParams{});
  cv::setNumThreads(int(state.range(2)));
  return c;
}

// The detector's input as PpocrDetector::detect makes it (letterboxed, ImageNet-normalised),
// and the valid part and scale of its map; for timing the network and the post-processing apart.
cv::Mat detector_blob(const cv::Mat& bgr, cv::Size input, cv::Size& fitted, float& scale) {
  scale = std::min(float(input.width) / float(bgr.cols), float(input.height) / float(bgr.rows));
  fitted = {std::min(cvRound(float(bgr.cols) * scale), input.width),
            std::min(cvRound(float(bgr.rows) * scale), input.height)};
  cv::Mat resized, normalised;
  cv::resize(bgr, resized, fitted, 0, 0, cv::INTER_LINEAR);
  resized.convertTo(normalised, CV_32FC3, 1.0 / 255.0);
  normalised -= cv::Scalar(0.485, 0.456, 0.406);
  cv::divide(normalised, cv::Scalar(0.229, 0.224, 0.225), normalised);
  cv::Mat padded(input, CV_32FC3, cv::Scalar::all(0));
  normalised.copyTo(padded(cv::Rect(cv::Point(0, 0), fitted)));
  return cv::dnn::blobFromImage(padded);
}

// The whole of detect(): letterbox, network, DB post-processing.
void BM_PpocrDetect(benchmark::State& state) {
  auto c = detector_case(state);
  if (!c) return;
  std::size_t lines = 0;
  for (auto _ : state) {
    lines = c->detector->detect(c->image).size();
    benchmark::DoNotOptimize(lines);
  }
  state.counters["lines"] = double(lines);
}

// The detector's network pass alone, with the float stand-in layers the detector uses; the FPN's
// RSE layers' 1x1 convolutions scaled and summed by the sums after them or (excited_sums 0)
// written, pooled, scaled and summed layer by layer.
void BM_PpocrDetectorNet(benchmark::State& state) {
  auto c = detector_case(state);
  if (!c) return;
  cv::Size fitted;
  float scale = 1;
  const cv::Mat blob = detector_blob(c->image, c->detector->input_size(), fitted, scale);
  keyfleet::vision::DnnLayers layers = keyfleet::vision::DnnLayers::in_float();
  layers.excited_sums = state.range(3) != 0;
  cv::dnn::Net net;
  {
    const keyfleet::vision::DnnLayersScope stand_ins(layers);
    net = keyfleet::vision::load_onnx_network(c->model, "ppocr detector");
    net.setInput(blob);
    net.forward();  // the first pass creates the layers and allocates
  }
  for (auto _ : state) {
    net.setInput(blob);
    cv::Mat out = net.forward();
    benchmark::DoNotOptimize(out.data);
  }
}

// DB post-processing of the photo's probability map alone (one thread: it is serial code).
void BM_PpocrDbPostprocess(benchmark::State& state) {
  auto c = detector_case(state);
  if (!c) return;
  cv::dnn::Net net = cv::dnn::readNetFromONNX(c->model);
  cv::Size fitted;
  float scale = 1;
  const cv::Size input = c->detector->input_size();
  net.setInput(detector_blob(c->image, input, fitted, scale));
  const cv::Mat out = net.forward();
  const cv::Mat prob = cv::Mat(input, CV_32F, const_cast<float*>(out.ptr<float>())).clone();
  std::size_t lines = 0;
  for (auto _ : state) {
    lines = keyfleet::vision::db_postprocess(prob, fitted, scale, c->image.size(), {}).size();
    benchmark::DoNotOptimize(lines);
  }
  state.counters["lines"] = double(lines);
}

// A real word crop (train_words/word_7.png, 137x53, "fusionopolis") read by a recogniser
// holding only the `width` network: every crop goes through that width (padded or squeezed).
struct RecognizerCase {
  std::unique_ptr<PpocrRecognizer> recognizer;
  cv::Mat crop;
  TextQuad quad;
  std::string model;
};

// `latin`: the station's files, the classifier cut to the Latin classes (ppocr_latin_only).
std::optional<RecognizerCase> recognizer_case(benchmark::State& state, int width, bool int8 = false,
                                              bool latin = false) {
  std::string why;
  const auto model = ppocr_file(
      (latin ? "ppocr_rec_latin_w" : "ppocr_rec_w") + std::to_string(width) + ".onnx", why);
  const auto keys = ppocr_file(latin ? "ppocr_keys_latin.txt" : "ppocr_keys_v1.txt", why);
  if (!model || !keys) {
    state.SkipWithError(why.c_str());
    return std::nullopt;
  }
  RecognizerCase c;
  c.model = *model;
  c.crop = cv::imread((data_dir() / "icdar2015/train_words/word_7.png").string());
  if (c.crop.empty()) {
    state.SkipWithError(
        "no ICDAR 2015 word crop (icdar2015/train_words/word_7.png under "
        "KEYFLEET_DATA)");
    return std::nullopt;
  }
  const float w = float(c.crop.cols), h = float(c.crop.rows);
  c.quad = {cv::Point2f(0, 0), cv::Point2f(w, 0), cv::Point2f(w, h), cv::Point2f(0, h)};
  keyfleet::station::RecognizerOptions options;
  options.layers.int8_pointwise = int8;
  c.recognizer = std::make_unique<PpocrRecognizer>(std::map<int, std::string>{{width, *model}},
                                                   *keys, options);
  return c;
}

// arg 0 = the network's input width (96 to 640), arg 1 = OpenCV threads, arg 2 = int8 1x1
// convolutions, arg 3 = the Latin files (the station's default) instead of the whole list.
void BM_PpocrRecognize(benchmark::State& state) {
  auto c = recognizer_case(state, int(state.range(0)), state.range(2) != 0, state.range(3) != 0);
  if (!c) return;
  cv::setNumThreads(int(state.range(1)));
  std::size_t words = 0;
  std::string text;
  for (auto _ : state) {
    const auto line = c->recognizer->recognize(c->crop, c->quad);
    words = line ? line->words.size() : 0;
    if (words > 0) text = line->words.front().text;
    benchmark::DoNotOptimize(words);
  }
  state.counters["words"] = double(words);
  state.SetLabel(text);
}

// What recognize() does besides the network: the perspective cut and greedy CTC decoding of
// the width-`arg 0` network's output for the crop.
void BM_PpocrRecognizerOverhead(benchmark::State& state) {
  const int width = int(state.range(0));
  auto c = recognizer_case(state, width);
  if (!c) return;
  cv::setNumThreads(1);
  cv::dnn::Net net = cv::dnn::readNetFromONNX(c->model);
  const int shape[] = {1, 3, PpocrRecognizer::kHeight, width};
  net.setInput(cv::Mat(4, shape, CV_32F, cv::Scalar(0.1)));
  const cv::Mat out = net.forward();
  const cv::Mat probs =
      cv::Mat(out.size[1], out.size[2], CV_32F, const_cast<float*>(out.ptr<float>())).clone();
  keyfleet::station::ppocr::CtcOptions options;
  options.allowed = keyfleet::station::ppocr::latin_classes(c->recognizer->classes());
  for (auto _ : state) {
    bool rotated = false;
    const cv::Mat cut = keyfleet::station::ppocr::crop_quad(c->crop, c->quad, &rotated);
    const auto line = keyfleet::station::ppocr::ctc_decode(probs, c->recognizer->classes(), width,
                                                           width / 2, c->quad, rotated, options);
    benchmark::DoNotOptimize(cut.data);
    benchmark::DoNotOptimize(line.words.size());
  }
}

// Where a pass of arg 0's network (0: the detector at 640x480, 1: the Latin recogniser at width
// 160) spends its time, by layer type (OpenCV's per-layer profile, summed over a pass and
// averaged over the iterations; a fused pair counts under its first layer's type), with the
// station's layers: the float stand-ins, the wide 1x1 convolutions in int8. One thread.
void BM_PpocrLayerTypes(benchmark::State& state) {
  const bool detector = state.range(0) == 0;
  std::string why;
  const auto model =
      ppocr_file(detector ? "ppocr_det_640x480.onnx" : "ppocr_rec_latin_w160.onnx", why);
  if (!model) {
    state.SkipWithError(why.c_str());
    return;
  }
  cv::setNumThreads(1);
  const int shape[] = {1, 3, detector ? 480 : PpocrRecognizer::kHeight, detector ? 640 : 160};
  cv::Mat input(4, shape, CV_32F);
  cv::randu(input, -1, 1);
  keyfleet::vision::DnnLayers layers = keyfleet::vision::DnnLayers::in_float();
  layers.int8_pointwise = true;
  cv::dnn::Net net;
  {
    const keyfleet::vision::DnnLayersScope stand_ins(layers);
    net = keyfleet::vision::load_onnx_network(*model, "ppocr");
    net.setInput(input);
    net.forward();  // the first pass creates, fuses and allocates the layers
  }
  std::map<std::string, double> ms_by_type;
  std::vector<double> ticks;
  for (auto _ : state) {
    net.setInput(input);
    benchmark::DoNotOptimize(net.forward().data);
    net.getPerfProfile(ticks);
    for (std::size_t i = 0; i < ticks.size(); ++i)
      ms_by_type[net.getLayer(int(i) + 1)->type] += ticks[i] * 1e3 / cv::getTickFrequency();
  }
  for (const auto& [type, ms] : ms_by_type)
    if (ms > 0) state.counters[type] = ms / double(state.iterations());
  if (std::getenv("KEYFLEET_LAYERS")) {  // each layer of the last pass, with its shapes
    const cv::dnn::MatShape input_shape(shape, shape + 4);
    const auto text = [](const std::vector<cv::dnn::MatShape>& s) {  // the first blob's shape
      std::string out;
      for (int v : s.empty() ? cv::dnn::MatShape{} : s[0])
        out += (out.empty() ? "" : "x") + std::to_string(v);
      return out;
    };
    for (std::size_t i = 0; i < ticks.size(); ++i) {
      std::vector<cv::dnn::MatShape> ins, outs;
      net.getLayerShapes(input_shape, int(i) + 1, ins, outs);
      const cv::Ptr<cv::dnn::Layer> layer = net.getLayer(int(i) + 1);
      std::printf("%-36s %-34s %7.3f ms  %s -> %s\n", layer->name.c_str(), layer->type.c_str(),
                  ticks[i] * 1e3 / cv::getTickFrequency(), text(ins).c_str(), text(outs).c_str());
    }
  }
  state.SetLabel(detector ? "detector 640x480, ms by layer type" : "recogniser w160, ms by type");
}

void timed(benchmark::internal::Benchmark* b) {
  b->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Repetitions(5)
      ->ReportAggregatesOnly(true)
      ->ComputeStatistics("min", [](const std::vector<double>& v) {
        return *std::min_element(v.begin(), v.end());
      });
}

}  // namespace

BENCHMARK_CAPTURE(read_keyframe, tesseract, std::string("tesseract"))->Apply(timed)->Iterations(5);
BENCHMARK_CAPTURE(read_keyframe, mininet_tesseract, std::string("mininet+tesseract"))
    ->Apply(timed)
    ->Iterations(5);
BENCHMARK_CAPTURE(read_keyframe, ppocr, std::string("ppocr"))->Apply(timed)->Iterations(5);
BENCHMARK_CAPTURE(read_keyframe, ppocr_float, std::string("ppocr"), false)
    ->Apply(timed)
    ->Iterations(5);

BENCHMARK(BM_PpocrDetect)
    ->ArgNames({"det640x480_0_det1280x736_1", "photo1280x720_0_resized640x480_1", "threads"})
    ->ArgsProduct({{0, 1}, {0, 1}, {1, 2}})
    ->Apply(timed)
    ->Iterations(3);
BENCHMARK(BM_PpocrDetectorNet)
    ->ArgNames({"det640x480_0_det1280x736_1", "photo1280x720_0_resized640x480_1", "threads",
                "excited_sums"})
    ->ArgsProduct({{0, 1}, {1}, {1, 2}, {0, 1}})
    ->Apply(timed)
    ->Iterations(3);
BENCHMARK(BM_PpocrDbPostprocess)
    ->ArgNames({"det640x480_0_det1280x736_1", "photo1280x720_0_resized640x480_1", "threads"})
    ->ArgsProduct({{0, 1}, {0, 1}, {1}})
    ->Apply(timed)
    ->Iterations(20);
BENCHMARK(BM_PpocrRecognize)
    ->ArgNames({"width", "threads", "int8", "latin"})
    ->ArgsProduct({{96, 160, 224, 320, 640}, {1, 2}, {0, 1}, {0, 1}})
    ->Apply(timed)
    ->Iterations(10);
BENCHMARK(BM_PpocrLayerTypes)
    ->ArgNames({"det640x480_0_rec160_1"})
    ->Args({0})
    ->Args({1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(30);
BENCHMARK(BM_PpocrRecognizerOverhead)
    ->ArgNames({"width"})
    ->Args({160})
    ->Args({640})
    ->Apply(timed)
    ->Iterations(50);

int main(int argc, char** argv) {
  // As the station: Tesseract's OpenMP threads bounded to one (OMP_THREAD_LIMIT, re-executes).
  keyfleet::limit_openmp_to_one_thread(argv);
  return keyfleet::bench::run_benchmarks_with_cpu_class(argc, argv);
}
