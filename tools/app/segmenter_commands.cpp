// `keyfleet segmenter eval`: the agent's text segmenter measured like Table III of Alonso et
// al. (ICRA 2019)
// (recall, precision and IoU of the text class, GFLOPs, CPU ms on 1 and 2 threads) at several
// input sizes, and the inference variants of vision/dnn_layers.hpp timed side by side.
#include <opencv2/core.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/segmenter_eval.hpp"
#include "keyfleet/vision/cpu_class.hpp"
#include "keyfleet/vision/model_files.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

// models/mininet/train.py trains on ICDAR 2015 test_blurred after its first 100 photos
// (img_101..200 in name order): only those 100 are held out for this evaluation. Of ICDAR 2015
// train it trains on all but the ids divisible by 10, its validation split, scored here.
constexpr std::size_t kBlurredHeldOut = 100;

struct SegmenterEvalOptions {
  std::string model = "mininet_text.onnx";
  std::vector<std::string> compare;  // other exports of a model, timed and scored beside it
  std::string generated;             // held-out image + mask pairs
  std::string data = "../shared/data";
  std::size_t max_images = 0;
  int repetitions = 15;
  bool profile = false;  // per layer type, at the first size
  std::vector<std::string> sizes = {"512x256", "256x128", "512x384", "320x256", "256x192"};
};

cv::Size parse_size(const std::string& text, int multiple) {
  int w = 0, h = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w <= 0 || h <= 0)
    throw StartupError("segmenter eval: size '" + text + "' is not WIDTHxHEIGHT");
  if (w % multiple || h % multiple)
    throw StartupError("segmenter eval: size " + text + " is not a multiple of " +
                       std::to_string(multiple) + " (the model's size_multiple)");
  return {w, h};
}

struct Variant {
  std::string model, label;
  vision::DnnLayers layers;
};

// Each model with OpenCV's layers, with the SELU and depthwise stand-ins (the default until the
// matrix-product ones), and with all stand-ins (the default), timed taking turns so that a noisy
// machine hits them alike.
void print_variant_timings(const std::vector<Variant>& variants, const std::vector<cv::Size>& sizes,
                           int repetitions) {
  std::printf("\nms per forward pass (median of %d, the variants taking turns)\n", repetitions);
  std::printf("%-10s %-34s %9s %6s %9s %6s\n", "input", "variant", "1 thread", "ratio", "2 threads",
              "ratio");
  for (const auto& size : sizes) {
    std::vector<std::unique_ptr<vision::DnnTextSegmenter>> nets;
    std::vector<vision::TextSegmenter*> segmenters;
    for (const auto& v : variants) {
      nets.push_back(std::make_unique<vision::DnnTextSegmenter>(v.model, 0, size, v.layers));
      segmenters.push_back(nets.back().get());
    }
    std::vector<std::vector<double>> ms;  // per thread count, per variant
    for (int threads : {1, 2}) {
      cv::setNumThreads(threads);
      ms.push_back(eval::median_forward_ms(segmenters, repetitions));
    }
    for (std::size_t k = 0; k < variants.size(); ++k)
      std::printf("%4dx%-5d %-34s %9.1f %6.2f %9.1f %6.2f\n", size.width, size.height,
                  variants[k].label.c_str(), ms[0][k], ms[0][k] / ms[0][0], ms[1][k],
                  ms[1][k] / ms[1][0]);
  }
}

// ms per layer type on one thread (OpenCV's per-layer timers), median over the repetitions, the
// variants taking turns; then each variant's costliest layers.
void print_layer_profile(const std::vector<Variant>& variants, cv::Size size, int repetitions) {
  std::vector<std::unique_ptr<vision::DnnTextSegmenter>> nets;
  const cv::Mat frame(size, CV_8UC3, cv::Scalar(90, 120, 150));
  for (const auto& v : variants) {
    nets.push_back(std::make_unique<vision::DnnTextSegmenter>(v.model, 1, size, v.layers));
    nets.back()->segment({frame});  // warm-up
  }
  cv::setNumThreads(1);
  std::vector<std::map<std::string, std::vector<double>>> ms(variants.size()),
      by_layer(variants.size());
  std::vector<std::map<std::string, std::string>> layer_type(variants.size());
  for (int i = 0; i < repetitions; ++i)
    for (std::size_t k = 0; k < nets.size(); ++k) {
      nets[k]->segment({frame});
      double total = 0;
      for (const auto& [type, t] : nets[k]->last_forward_ms_by_type()) {
        ms[k][type].push_back(t);
        total += t;
      }
      ms[k]["(all layers)"].push_back(total);
      for (const auto& layer : nets[k]->last_forward_layers()) {
        by_layer[k][layer.name].push_back(layer.ms);
        layer_type[k][layer.name] = layer.type;
      }
    }
  const auto median = [](std::vector<double>& t) {
    std::nth_element(t.begin(), t.begin() + long(t.size() / 2), t.end());
    return t[t.size() / 2];
  };
  std::printf("\nms per layer type, 1 thread, %dx%d (median of %d, the variants taking turns)\n",
              size.width, size.height, repetitions);
  for (std::size_t k = 0; k < variants.size(); ++k) {
    std::printf("%s\n", variants[k].label.c_str());
    for (auto& [type, t] : ms[k])
      if (const double m = median(t); m >= 0.005) std::printf("  %-32s %8.2f\n", type.c_str(), m);
  }
  constexpr std::size_t kCostliest = 8;
  for (std::size_t k = 0; k < variants.size(); ++k) {
    std::vector<std::pair<double, std::string>> layers;
    for (auto& [name, t] : by_layer[k]) layers.emplace_back(median(t), name);
    std::sort(layers.rbegin(), layers.rend());
    std::printf("%s: the %zu costliest layers\n", variants[k].label.c_str(),
                std::min(kCostliest, layers.size()));
    for (std::size_t i = 0; i < layers.size() && i < kCostliest; ++i)
      std::printf("  %-40s %-32s %8.2f\n", layers[i].second.c_str(),
                  layer_type[k][layers[i].second].c_str(), layers[i].first);
  }
}

struct Set {
  std::string name;
  std::function<eval::SegmentationScores(vision::TextSegmenter&)> run;
  bool present;
};

std::vector<Set> evaluation_sets(const SegmenterEvalOptions& o) {
  const fs::path icdar = fs::path(o.data) / "icdar2015";
  const std::size_t blurred =
      o.max_images ? std::min(o.max_images, kBlurredHeldOut) : kBlurredHeldOut;
  return {{"generated (held out)",
           [&o](vision::TextSegmenter& s) {
             return eval::evaluate_on_pairs(s, o.generated, o.max_images);
           },
           !o.generated.empty() && fs::is_directory(o.generated)},
          {"icdar2015 train, val",
           [&o, icdar](vision::TextSegmenter& s) {
             return eval::evaluate_on_icdar(s, (icdar / "train/images").string(),
                                            (icdar / "train/gt").string(), o.max_images,
                                            eval::icdar_validation_id);
           },
           fs::is_directory(icdar / "train")},
          {"icdar2015 test_clean",
           [&o, icdar](vision::TextSegmenter& s) {
             return eval::evaluate_on_icdar(s, (icdar / "test_clean/images").string(),
                                            (icdar / "test_clean/gt").string(), o.max_images);
           },
           fs::is_directory(icdar / "test_clean")},
          {"icdar2015 test_blurred",
           [icdar, blurred](vision::TextSegmenter& s) {
             return eval::evaluate_on_icdar(s, (icdar / "test_blurred/images").string(),
                                            (icdar / "test_blurred/gt").string(), blurred);
           },
           fs::is_directory(icdar / "test_blurred")}};
}

int run_segmenter_eval(const SegmenterEvalOptions& o) {
  const std::string model = vision::locate_model(o.model, "segmenter model");
  const auto info = vision::read_segmenter_info(model);
  std::printf("model %s: %s\n", model.c_str(), info.description.c_str());
  std::vector<cv::Size> sizes;
  for (const auto& text : o.sizes) sizes.push_back(parse_size(text, info.size_multiple));

  std::vector<Variant> variants;
  std::vector<std::string> models;
  for (std::size_t i = 0; i <= o.compare.size(); ++i) {
    const std::string path = i ? vision::locate_model(o.compare[i - 1], "segmenter model") : model;
    models.push_back(path);
    if (i) std::printf("compare %zu: %s\n", i, path.c_str());
    const std::string name = i ? "compare " + std::to_string(i) : "model";
    variants.push_back({path, name + ", OpenCV layers", vision::DnnLayers::opencv()});
    vision::DnnLayers selu_depthwise = vision::DnnLayers::opencv();
    selu_depthwise.vectorised_selu = selu_depthwise.depthwise = true;
    variants.push_back({path, name + ", SELU + depthwise", selu_depthwise});
    variants.push_back({path, name + ", all stand-ins, float", vision::DnnLayers::in_float()});
    vision::DnnLayers int8 = vision::DnnLayers::in_float();
    int8.int8_pointwise = true;
    variants.push_back({path, name + ", all stand-ins, int8 1x1", int8});
    if (vision::bfloat16_products_supported()) {
      variants.push_back({path, name + ", all stand-ins, bfloat16", vision::DnnLayers{}});
      int8.bfloat16_products = true;
      variants.push_back({path, name + ", bfloat16, int8 1x1", int8});
    }
  }
  print_variant_timings(variants, sizes, o.repetitions);
  if (o.profile) print_layer_profile(variants, sizes.at(0), o.repetitions);

  const auto sets = evaluation_sets(o);
  // Each variant on each set: the stand-ins must score what OpenCV's layers score.
  std::printf("\n%-24s %-34s %7s %7s %7s %7s\n", "set (512x256)", "variant", "images", "R %", "P %",
              "IoU %");
  for (const auto& set : sets) {
    if (!set.present) continue;
    for (const auto& v : variants) {
      vision::DnnTextSegmenter net(v.model, 2, cv::Size(512, 256), v.layers);
      const auto s = set.run(net);
      std::printf("%-24s %-34s %7zu %7.2f %7.2f %7.2f\n", set.name.c_str(), v.label.c_str(),
                  s.images, 100 * s.recall, 100 * s.precision, 100 * s.iou);
    }
  }

  // Table III: the agent's default inference path (SemanticConfig's stand-ins), per input size,
  // each model. FLOPs of a fully convolutional network grow with the pixel count.
  const vision::DnnLayers agent_layers = vision::semantic_layers(SemanticConfig{});
  std::printf("\nTable III (the agent's default layers: %s; ms: median of %d forward passes)\n",
              vision::segmenter_kernels(agent_layers.bfloat16_products, agent_layers.int8_pointwise)
                  .c_str(),
              o.repetitions);
  std::printf("%-9s %-24s %-9s %7s %7s %7s %7s %7s %8s %8s %6s\n", "model", "set", "input",
              "images", "R %", "P %", "IoU %", "GFLOPs", "ms 1 thr", "ms 2 thr", "rank");
  for (std::size_t m = 0; m < models.size(); ++m) {
    const std::string& path = models[m];
    const auto model_info = vision::read_segmenter_info(path);
    const std::string label = m ? "compare " + std::to_string(m) : "model";
    for (const auto& size : sizes) {
      vision::DnnTextSegmenter net(path, 0, size, agent_layers);
      std::vector<vision::TextSegmenter*> one = {&net};
      cv::setNumThreads(1);
      const double ms1 = eval::median_forward_ms(one, o.repetitions).at(0);
      cv::setNumThreads(2);
      const double ms2 = eval::median_forward_ms(one, o.repetitions).at(0);
      const double gflops = model_info.gflops_512x256 * size.area() / (512.0 * 256.0);
      for (const auto& set : sets) {
        if (!set.present) continue;
        const auto s = set.run(net);
        std::printf("%-9s %-24s %4dx%-4d %7zu %7.2f %7.2f %7.2f %7.3f %8.1f %8.1f %6.2f\n",
                    label.c_str(), set.name.c_str(), size.width, size.height, s.images,
                    100 * s.recall, 100 * s.precision, 100 * s.iou, gflops, ms1, ms2,
                    s.frame_rank_correlation);
      }
    }
  }
  for (const auto& set : sets)
    if (!set.present) std::printf("%-24s (not found: skipped)\n", set.name.c_str());
  std::printf(
      "rank: Spearman's rho between each image's share of text found and its true share (does "
      "the\nsemantic score rank frames as their text does?).\n");
  std::printf(
      "\nThe paper's MiniNet on COCO-Text: R 52.61, P 36.69, IoU 27.63, 1.06 GFLOPs, "
      "18 ms (i5-8600k).\n");
  return 0;
}

}  // namespace

void add_segmenter_commands(CLI::App& app) {
  auto* segmenter = app.add_subcommand("segmenter", "the agent's text segmenter");
  segmenter->require_subcommand(1);
  auto* eval = segmenter->add_subcommand(
      "eval", "accuracy and CPU time, like Table III of Alonso et al. 2019");
  auto o = std::make_shared<SegmenterEvalOptions>();
  eval->add_option("--model", o->model, "ONNX model with its .json");
  eval->add_option("--compare", o->compare,
                   "other exports (with their .json) timed and scored beside it");
  eval->add_option("--generated", o->generated, "held-out pairs from keyfleet scenario training");
  eval->add_option("--data", o->data, "the shared data folder (ICDAR photos)");
  eval->add_option("--max-images", o->max_images,
                   "per set; 0 = all (test_blurred: at most its first 100, the held-out ones)");
  eval->add_option("--repetitions", o->repetitions, "timed forward passes")
      ->check(CLI::Range(1, 10000));
  eval->add_flag("--profile", o->profile,
                 "ms per layer type of each variant at the first size on one thread, and its 8 "
                 "costliest layers");
  eval->add_option("--sizes", o->sizes, "input sizes WIDTHxHEIGHT")->capture_default_str();
  eval->callback([o] { run_reporting([&] { run_segmenter_eval(*o); }); });
}

}  // namespace keyfleet::commands
