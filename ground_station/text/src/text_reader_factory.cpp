#include "keyfleet/common/error.hpp"
#include "keyfleet/station/text_reader.hpp"
#include "readers.hpp"

namespace keyfleet::station {

std::vector<std::string> text_reader_engines() { return {"tesseract", "mininet+tesseract"}; }

std::unique_ptr<TextReader> make_text_reader(const TextReaderParams& params) {
  if (params.min_confidence < 0 || params.min_confidence > 1)
    throw StartupError("text reader: min_confidence " + std::to_string(params.min_confidence) +
                       " is outside 0..1");
  if (params.min_word_length < 1)
    throw StartupError("text reader: min_word_length must be at least 1");
  if (params.engine == "tesseract") return std::make_unique<TesseractReader>(params);
  if (params.engine == "mininet+tesseract") return std::make_unique<DetectRecogniseReader>(params);
  std::string known;
  for (const auto& e : text_reader_engines()) known += (known.empty() ? "" : ", ") + e;
  throw StartupError("text reader: unknown engine '" + params.engine + "' (known: " + known + ")");
}

}  // namespace keyfleet::station
