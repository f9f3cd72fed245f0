#include <functional>

#include "keyfleet/common/error.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "readers.hpp"

namespace keyfleet::station {
namespace {

struct Engine {
  const char* name;
  std::function<std::unique_ptr<TextReader>(const TextReadingConfig&)> make;
};

// Every engine, once: a new engine is a TextReader class and one line here.
const std::vector<Engine>& engines() {
  static const std::vector<Engine> all = {
      {"tesseract", [](const auto& c) { return std::make_unique<TesseractReader>(c); }},
      {"mininet+tesseract",
       [](const auto& c) { return std::make_unique<DetectRecogniseReader>(c); }},
      {"ppocr", [](const auto& c) { return std::make_unique<PpocrReader>(c); }},
  };
  return all;
}

}  // namespace

LexiconReader::LexiconReader(std::unique_ptr<TextReader> engine, const std::string& lexicon_path)
    : engine_(std::move(engine)), lexicon_(lexicon_path) {}

std::vector<ReadWord> LexiconReader::read(const cv::Mat& bgr) { return listed(engine_->read(bgr)); }

std::vector<ReadWord> LexiconReader::read_with_hints(const cv::Mat& bgr,
                                                     const std::vector<cv::Rect>& hints) {
  return listed(engine_->read_with_hints(bgr, hints));
}

std::vector<ReadWord> LexiconReader::listed(std::vector<ReadWord> read) const {
  std::vector<ReadWord> words;
  for (auto& word : read) {
    auto listed = apply_lexicon(lexicon_, word.text);
    if (!listed) continue;
    word.text = std::move(*listed);
    words.push_back(std::move(word));
  }
  return words;
}

std::vector<std::string> text_reader_engines() {
  std::vector<std::string> names;
  for (const auto& engine : engines()) names.push_back(engine.name);
  return names;
}

std::unique_ptr<TextReader> make_text_reader(const TextReadingConfig& config) {
  if (!(config.min_confidence >= 0 && config.min_confidence <= 1))
    throw StartupError("text reader: min_confidence " + std::to_string(config.min_confidence) +
                       " is outside 0..1");
  if (config.min_word_length < 1)
    throw StartupError("text reader: min_word_length must be at least 1");
  for (const auto& engine : engines()) {
    if (config.engine != engine.name) continue;
    auto reader = engine.make(config);
    if (config.lexicon.empty()) return reader;
    return std::make_unique<LexiconReader>(std::move(reader), config.lexicon);
  }
  std::string known;
  for (const auto& name : text_reader_engines()) known += (known.empty() ? "" : ", ") + name;
  throw StartupError("text reader: unknown engine '" + config.engine + "' (known: " + known + ")");
}

}  // namespace keyfleet::station
