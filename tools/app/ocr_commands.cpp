// `keyfleet ocr`: the station's text readers on real photos (ICDAR 2015 end-to-end protocol,
// cropped-word accuracy, time per image) and on one image.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/common/config.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/eval/text_dataset_eval.hpp"
#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::commands {
namespace {

std::string join_widths(const std::vector<int>& widths) {
  std::string out;
  for (int w : widths) out += (out.empty() ? "" : ", ") + std::to_string(w);
  return out;
}

namespace fs = std::filesystem;

struct OcrOptions {
  TextReadingConfig params;
  std::vector<std::string> engines;
  std::string data = "../shared/data";
  std::size_t max_images = 0;
  std::string image;
};

// Median ms per 640x480 keyframe: the train_sharp photos resized to that size.
double keyframe_ms(station::TextReader& reader, const fs::path& images) {
  std::vector<double> ms;
  for (const auto& entry : fs::directory_iterator(images)) {
    const cv::Mat photo = cv::imread(entry.path().string(), cv::IMREAD_COLOR);
    if (photo.empty()) continue;
    cv::Mat keyframe;
    cv::resize(photo, keyframe, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
    ms.push_back(eval::median_read_ms(reader, keyframe, 1));
  }
  if (ms.empty()) return 0.0;
  std::nth_element(ms.begin(), ms.begin() + long(ms.size() / 2), ms.end());
  return ms[ms.size() / 2];
}

void run_eval(const OcrOptions& o) {
  const fs::path data(o.data);
  const fs::path sharp = data / "icdar2015/train_sharp", blurred = data / "icdar2015/test_blurred";
  const fs::path clean = data / "icdar2015/test_clean";
  const fs::path words = data / "words_mmocr";
  const bool with_blurred = o.max_images > 0 && fs::is_directory(blurred);
  const bool with_clean = o.max_images > 0 && fs::is_directory(clean);
  std::printf(
      "min confidence %.2f, min word length %d, min long side %d px, thresholding %d, "
      "segmenter widths %s, ppocr detector %s\n",
      double(o.params.min_confidence), o.params.min_word_length, o.params.min_long_side,
      o.params.thresholding_method, join_widths(o.params.segmenter_widths).c_str(),
      o.params.ppocr_detector_size.c_str());
  std::printf(
      "end-to-end: ICDAR 2015 protocol (polygon IoU >= 0.5, case-insensitive text, ### "
      "ignored); words: exact, case-insensitive\n\n");
  std::printf("%-18s | %-20s | %-26s | %-26s | %-10s | %-8s %-8s\n", "engine",
              "train_sharp R/P/F %", with_clean ? "test_clean R/P/F % (n)" : "test_clean",
              with_blurred ? "test_blurred R/P/F % (n)" : "test_blurred", "words", "ms 1280",
              "ms 640");
  const std::vector<std::string> engines =
      o.engines.empty() ? station::text_reader_engines() : o.engines;
  for (const auto& engine : engines) {
    TextReadingConfig params = o.params;
    params.engine = engine;
    std::unique_ptr<station::TextReader> reader;
    try {
      reader = station::make_text_reader(params);
    } catch (const StartupError& e) {
      // Comparing all engines: one whose optional models are absent (ppocr before
      // scripts/fetch_ppocr.sh) is reported, not fatal. A named engine must start.
      if (!o.engines.empty()) throw;
      std::printf("%-18s | not available: %s\n", engine.c_str(), e.what());
      continue;
    }
    const auto e2e = eval::evaluate_end_to_end(*reader, sharp.string(), o.max_images);
    // The first --max-images photos of a test set, as one cell of the table.
    const auto test_set_cell = [&](bool wanted, const fs::path& set) {
      if (!wanted) return std::string("(give --max-images)");
      const auto r = eval::evaluate_end_to_end(*reader, set.string(), o.max_images);
      char cell[64];
      std::snprintf(cell, sizeof cell, "%5.1f %5.1f %5.1f (%zu)", 100 * r.counts.recall(),
                    100 * r.counts.precision(), 100 * r.counts.f_score(), r.images);
      return std::string(cell);
    };
    const std::string clean_cell = test_set_cell(with_clean, clean);
    const std::string blurred_cell = test_set_cell(with_blurred, blurred);
    const auto w = eval::evaluate_cropped_words(*reader, words.string());
    std::printf("%-18s | %5.1f %5.1f %5.1f      | %-26s | %-26s | %2zu/%-2zu     | %8.0f %8.0f\n",
                engine.c_str(), 100 * e2e.counts.recall(), 100 * e2e.counts.precision(),
                100 * e2e.counts.f_score(), clean_cell.c_str(), blurred_cell.c_str(), w.correct,
                w.words, e2e.median_ms, keyframe_ms(*reader, sharp / "images"));
    std::fflush(stdout);
  }
}

void run_read(const OcrOptions& o) {
  const cv::Mat image = cv::imread(o.image, cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error("cannot read image " + o.image);
  TextReadingConfig params = o.params;
  if (!o.engines.empty()) params.engine = o.engines.front();
  const auto reader = station::make_text_reader(params);
  const auto words = reader->read(image);
  std::printf("%s: %zu words (%s)\n", o.image.c_str(), words.size(), reader->name().c_str());
  for (const auto& w : words)
    std::printf("%-24s %5.2f  x %4d y %4d w %4d h %4d\n", w.text.c_str(), double(w.confidence),
                w.box.x, w.box.y, w.box.width, w.box.height);
}

void add_reader_options(CLI::App& command, OcrOptions& o) {
  // Added first, so that CLI11 applies the file before the flags below override its values.
  command
      .add_option_function<std::string>(
          "--config",
          [&o](const std::string& path) {
            try {
              o.params = load_station_config(path).analysis.text;
            } catch (const std::exception& e) {  // reported by CLI11 as a bad option value
              throw CLI::ValidationError("--config", e.what());
            }
          },
          "a station config whose analysis.text section is the reader (default: the station's "
          "defaults)")
      ->check(CLI::ExistingFile);
  command.add_option("--min-confidence", o.params.min_confidence, "drop words below (0..1)")
      ->check(CLI::Range(0.0, 1.0));
  command.add_option("--min-word-length", o.params.min_word_length, "drop shorter words");
  command.add_option("--min-word-height", o.params.min_word_height, "drop lower words (px)");
  command.add_option("--min-long-side", o.params.min_long_side,
                     "upscale smaller images to this longer side (px, 0 = never)");
  command.add_option("--segmenter-width", o.params.segmenter_widths,
                     "MiniNet input widths for mininet+tesseract (multiples of 64)");
  command.add_option("--line-height", o.params.region_line_height,
                     "px a word crop or detected line is scaled to before reading");
  command.add_option("--thresholding", o.params.thresholding_method,
                     "Tesseract binarisation: 0 Otsu, 1 tiled Otsu, 2 Sauvola");
  command.add_option("--tessdata", o.params.tessdata_dir, "Tesseract data folder");
  command.add_option("--ppocr-detector-size", o.params.ppocr_detector_size,
                     "ppocr detector input WxH (a converted size: 640x480 or 1280x736)");
  command
      .add_option("--ppocr-binary-threshold", o.params.ppocr_binary_threshold,
                  "ppocr: text probability of a text pixel (0..1)")
      ->check(CLI::Range(0.0, 1.0));
}

}  // namespace

void add_ocr_commands(CLI::App& app) {
  auto options = std::make_shared<OcrOptions>();
  auto* ocr = app.add_subcommand("ocr", "the station's text readers");
  ocr->require_subcommand(1);

  auto* eval = ocr->add_subcommand("eval", "engines on the shared data (ICDAR 2015 end-to-end)");
  eval->add_option("--data", options->data, "the shared data folder");
  eval->add_option("--engine", options->engines, "engines to compare (default: all)");
  eval->add_option("--max-images", options->max_images,
                   "images per ICDAR set; also adds test_clean and test_blurred (0 = "
                   "train_sharp only)");
  add_reader_options(*eval, *options);
  eval->callback([options] { run_reporting([&] { run_eval(*options); }); });

  auto* read = ocr->add_subcommand("read", "print the words read in one image");
  read->add_option("image", options->image, "image file")->required()->check(CLI::ExistingFile);
  read->add_option("--engine", options->engines, "engine (default: the config's)")->expected(1);
  add_reader_options(*read, *options);
  read->callback([options] { run_reporting([&] { run_read(*options); }); });
}

}  // namespace keyfleet::commands
