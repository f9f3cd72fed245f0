// `keyfleet ocr`: the station's text readers on real photos (ICDAR 2015 end-to-end protocol,
// cropped-word accuracy, time per photo and per word), with and without a lexicon, and on one
// image.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/file_output.hpp"
#include "keyfleet/eval/eval_runner.hpp"
#include "keyfleet/eval/photo_encoding.hpp"
#include "keyfleet/eval/run_text_score.hpp"
#include "keyfleet/eval/text_dataset_eval.hpp"
#include "keyfleet/station/station_config.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/vision/text_segmenter.hpp"

namespace keyfleet::commands {
namespace {

namespace fs = std::filesystem;

// The sets `keyfleet ocr eval` knows, under the shared data folder: photos with word
// quadrilaterals (ICDAR 2015 end-to-end) or cropped words (word accuracy).
struct DataSet {
  const char* name;
  const char* folder;
  bool photos;
};
constexpr DataSet kSets[] = {
    {"test_clean", "icdar2015/test_clean", true},
    {"test_blurred", "icdar2015/test_blurred", true},
    {"train", "icdar2015/train", true},
    {"train_sharp", "icdar2015/train_sharp", true},
    {"train_words", "icdar2015/train_words", false},
    {"words_mmocr", "words_mmocr", false},
};

const DataSet& find_set(const std::string& name) {
  for (const auto& set : kSets)
    if (name == set.name) return set;
  std::string known;
  for (const auto& set : kSets) known += std::string(known.empty() ? "" : ", ") + set.name;
  throw StartupError("ocr eval: unknown set '" + name + "' (known: " + known + ")");
}

struct OcrOptions {
  TextReadingConfig params;
  std::vector<std::string> engines;
  std::string data = std::getenv("KEYFLEET_DATA") ? std::getenv("KEYFLEET_DATA") : "../shared/data";
  std::vector<std::string> sets = {"test_clean", "test_blurred", "train", "train_words",
                                   "words_mmocr"};
  std::size_t max_images = 100;
  std::size_t max_words = 0;
  std::vector<std::string> lexicons = {"none", "/usr/share/dict/american-english"};
  std::string out;
  std::string image;
  std::vector<std::string> encodings;  // NAME=QUALITY[@SCALE][+text] (photo_encoding.hpp)
  int text_margin_px = 4;
};

std::string percent(double value) {
  char text[16];
  std::snprintf(text, sizeof text, "%.1f", 100 * value);
  return text;
}

// One row of the table: an engine with or without a lexicon, over every set.
std::string eval_row(station::TextReader& reader, const std::string& engine,
                     const std::string& lexicon, const OcrOptions& o) {
  std::string row = "| " + engine + " | " + lexicon;
  std::optional<double> photo_ms, word_ms;  // of the first set of each kind
  for (const auto& name : o.sets) {
    const DataSet& set = find_set(name);
    const std::string folder = (fs::path(o.data) / set.folder).string();
    if (set.photos) {
      const auto r = eval::evaluate_end_to_end(reader, folder, o.max_images);
      row += " | " + percent(r.counts.recall()) + " / " + percent(r.counts.precision()) + " / **" +
             percent(r.counts.f_score()) + "** (" + std::to_string(r.images) + ")";
      if (!photo_ms) photo_ms = r.median_ms;
    } else {
      const auto r = eval::evaluate_cropped_words(reader, folder, o.max_words);
      row += " | " + percent(r.accuracy()) + " (" + std::to_string(r.correct) + "/" +
             std::to_string(r.words) + ")";
      if (!word_ms) word_ms = r.median_ms;
    }
  }
  const auto ms_cell = [](std::optional<double> ms) {
    return ms ? std::to_string(std::lround(*ms)) : std::string("-");
  };
  return row + " | " + ms_cell(photo_ms) + " | " + ms_cell(word_ms) + " |\n";
}

// One row per encoding: the photo sets read as the robot would send them, with the bytes a photo
// took (the word sets are crops, not what a robot sends: left out).
std::string encoding_rows(station::TextReader& reader, const std::string& engine,
                          const std::string& lexicon, const OcrOptions& o,
                          const std::vector<EvalEncoding>& encodings,
                          const std::shared_ptr<vision::TextSegmenter>& segmenter) {
  std::string rows;
  for (const auto& encoding : encodings) {
    const auto link = eval::make_photo_link(encoding, o.text_margin_px, segmenter);
    std::string row = "| " + engine + " | " + lexicon + " | " + encoding.name;
    std::string kilobytes = "-";
    for (const auto& name : o.sets) {
      const DataSet& set = find_set(name);
      if (!set.photos) continue;
      const auto r = eval::evaluate_end_to_end(reader, (fs::path(o.data) / set.folder).string(),
                                               o.max_images, {}, link);
      row += " | " + percent(r.counts.recall()) + " / " + percent(r.counts.precision()) + " / **" +
             percent(r.counts.f_score()) + "** (" + std::to_string(r.images) + ")";
      if (kilobytes == "-" && r.images > 0) {
        char text[32];
        std::snprintf(text, sizeof text, "%.1f", double(r.bytes) / 1e3 / double(r.images));
        kilobytes = text;
      }
    }
    rows += row + " | " + kilobytes + " |\n";
    std::printf("%s", (row + " | " + kilobytes + " |\n").c_str());
    std::fflush(stdout);
  }
  return rows;
}

std::string encodings_header(const OcrOptions& o) {
  std::string table = "| engine | lexicon | encoding";
  std::string rule = "|---|---|---";
  for (const auto& name : o.sets)
    if (find_set(name).photos) {
      table += " | " + name + " R / P / F % (photos)";
      rule += "|---";
    }
  return table + " | kB a photo (first set) |\n" + rule + "|---|\n";
}

void run_eval(const OcrOptions& o) {
  std::vector<EvalEncoding> encodings;
  for (const auto& spec : o.encodings) {
    encodings.push_back(eval::parse_encoding_spec(spec));
    for (std::size_t i = 0; i + 1 < encodings.size(); ++i)
      if (encodings[i].name == encodings.back().name)
        throw ConfigError("--encoding: the name '" + encodings.back().name + "' is given twice");
  }
  if (!encodings.empty() && std::none_of(o.sets.begin(), o.sets.end(),
                                         [](const std::string& n) { return find_set(n).photos; }))
    throw ConfigError(
        "--encoding reads photo sets only (test_clean, test_blurred, train): none "
        "is among --sets");
  std::shared_ptr<vision::TextSegmenter> segmenter;
  if (std::any_of(encodings.begin(), encodings.end(),
                  [](const EvalEncoding& e) { return e.text_aware; }))
    segmenter = vision::make_text_segmenter(SemanticConfig{});  // the robot's, as shipped
  for (const auto& name : o.sets) {
    const DataSet& set = find_set(name);
    if (!fs::is_directory(fs::path(o.data) / set.folder))
      throw StartupError("ocr eval: no " + name + " under " + o.data + " (set --data or " +
                         "KEYFLEET_DATA to the shared data folder)");
  }
  std::string table = "| engine | lexicon";
  std::string rule = "|---|---";
  for (const auto& name : o.sets) {
    table += std::string(" | ") + name +
             (find_set(name).photos ? " R / P / F % (photos)" : " words % (right/all)");
    rule += "|---";
  }
  table += " | ms a photo | ms a word |\n" + rule + "|---|---|\n";
  if (!encodings.empty()) table = encodings_header(o);
  std::printf("%s", table.c_str());
  std::fflush(stdout);
  const std::vector<std::string> engines =
      o.engines.empty() ? station::text_reader_engines() : o.engines;
  for (const auto& engine : engines) {
    for (const auto& lexicon : o.lexicons) {
      TextReadingConfig params = o.params;
      params.engine = engine;
      params.lexicon = lexicon == "none" ? "" : lexicon;
      std::unique_ptr<station::TextReader> reader;
      try {
        reader = station::make_text_reader(params);
      } catch (const StartupError& e) {
        // Comparing all engines: one whose optional models are absent (ppocr before
        // scripts/fetch_ppocr.sh) is reported, not fatal. A named engine must start.
        if (!o.engines.empty()) throw;
        const std::string row =
            "| " + engine + " | " + lexicon + " | not available: " + e.what() + " |\n";
        std::printf("%s", row.c_str());
        table += row;
        continue;
      }
      if (!encodings.empty()) {
        table += encoding_rows(*reader, engine, fs::path(lexicon).filename().string(), o, encodings,
                               segmenter);
        continue;
      }
      const std::string row = eval_row(*reader, engine, fs::path(lexicon).filename().string(), o);
      std::printf("%s", row.c_str());
      std::fflush(stdout);
      table += row;
    }
  }
  if (!o.out.empty()) write_file(o.out, table);
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
  command.add_option("--segmenter-width", o.params.mininet.segmenter_widths,
                     "MiniNet input widths for mininet+tesseract (multiples of 64)");
  command.add_option("--line-height", o.params.tesseract.line_height,
                     "px a word crop or detected line is scaled to before reading");
  command.add_option("--thresholding", o.params.tesseract.thresholding_method,
                     "Tesseract binarisation: 0 Otsu, 1 tiled Otsu, 2 Sauvola");
  command.add_option("--tessdata", o.params.tesseract.tessdata_dir, "Tesseract data folder");
  command.add_option("--ppocr-detector-size", o.params.ppocr.detector_size,
                     "ppocr detector input: auto, or WxH (a converted size: 640x480 or 1280x736)");
  command
      .add_option("--ppocr-binary-threshold", o.params.ppocr.binary_threshold,
                  "ppocr: text probability of a text pixel (0..1)")
      ->check(CLI::Range(0.0, 1.0));
  command
      .add_option("--ppocr-box-threshold", o.params.ppocr.box_threshold,
                  "ppocr: min mean text probability of a kept line (0..1)")
      ->check(CLI::Range(0.0, 1.0));
  command
      .add_option("--ppocr-unclip-ratio", o.params.ppocr.unclip_ratio,
                  "ppocr: how far line boxes are grown (0..10)")
      ->check(CLI::Range(0.0, 10.0));
  command
      .add_option("--ppocr-space-probability", o.params.ppocr.space_probability,
                  "ppocr: split words where a space is this likely (0 = where it wins)")
      ->check(CLI::Range(0.0, 1.0));
  command.add_option("--cut-word-margin", o.params.ppocr.cut_word_margin,
                     "ppocr: drop words this close to the image's edge (px, -1 = keep)");
  command.add_option("--lexicon", o.params.lexicon,
                     "word list to correct readings against (one word a line; empty = none)");
  command.add_option("--ppocr-latin-only", o.params.ppocr.latin_only,
                     "ppocr: read Latin letters, digits and punctuation only (true/false)");
}

}  // namespace

void print_run_text_score(const std::string& run_dir, const std::string& scenario_dir) {
  const fs::path station = fs::path(run_dir) / "station";
  try {
    const auto score = eval::score_run_text(scenario_dir, (station / "station.sqlite").string());
    const std::string text = eval::format_run_text_score(score);
    std::cout << "\n" << text;
    write_file(station / "text_score.txt", text);
  } catch (const std::exception& e) {
    std::cout << "\nText read: not scored against the scenario: " << e.what() << "\n";
  }
}

void add_ocr_commands(CLI::App& app) {
  auto options = std::make_shared<OcrOptions>();
  auto* ocr = app.add_subcommand("ocr", "the station's text readers");
  ocr->require_subcommand(1);

  auto* eval = ocr->add_subcommand("eval", "engines on the shared data (ICDAR 2015 end-to-end)");
  eval->add_option("--data", options->data,
                   "the shared data folder (default: $KEYFLEET_DATA, else ../shared/data)");
  eval->add_option("--engine", options->engines, "engines to compare (default: all)");
  eval->add_option(
          "--sets", options->sets,
          "data sets, among test_clean test_blurred train train_sharp train_words words_mmocr")
      ->delimiter(',');
  eval->add_option("--max-images", options->max_images, "first photos of each photo set (0 = all)");
  eval->add_option("--max-words", options->max_words, "first words of each word set (0 = all)");
  eval->add_option("--lexicons", options->lexicons,
                   "a row per engine and word list ('none' = without)")
      ->delimiter(',');
  eval->add_option("--out", options->out, "also write the table (Markdown) to this file");
  eval->add_option("--encoding", options->encodings,
                   "read the photos as a robot would send them, one row each: "
                   "NAME=QUALITY[@SCALE][+text] (e.g. q55=55 ta40=40@0.5+text; text-aware "
                   "regions from the robot's semantic model); the table gives kB a photo");
  eval->add_option("--text-margin", options->text_margin_px,
                   "text-aware encodings: pixels kept around each text region")
      ->check(CLI::Range(0, 1000));
  add_reader_options(*eval, *options);
  eval->callback([options] { run_reporting([&] { run_eval(*options); }); });

  auto* score = ocr->add_subcommand(
      "score", "what a mission's station read against the scenario it replayed");
  score->add_option("run", options->image, "the mission's run folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  score->callback([options] {
    print_run_text_score(options->image, (fs::path(options->image) / "scenario").string());
  });

  auto* read = ocr->add_subcommand("read", "print the words read in one image");
  read->add_option("image", options->image, "image file")->required()->check(CLI::ExistingFile);
  read->add_option("--engine", options->engines, "engine (default: the config's)")->expected(1);
  add_reader_options(*read, *options);
  read->callback([options] { run_reporting([&] { run_read(*options); }); });
}

}  // namespace keyfleet::commands
