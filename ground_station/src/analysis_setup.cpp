#include "keyfleet/station/analysis_setup.hpp"

#include "keyfleet/common/model_files.hpp"

namespace keyfleet::station {

std::unique_ptr<PlaceRecognizer> make_configured_place_recognizer(
    const PlaceRecognitionConfig& config) {
  if (!config.enabled) return nullptr;
  auto vocabulary = std::make_shared<const OrbVocabulary>(
      OrbVocabulary::load(locate_model_file(config.vocabulary, "place recognition: vocabulary")));
  return std::make_unique<OrbBowPlaceRecognizer>(
      std::move(vocabulary), make_match_verifier(parse_verifier_kind(config.verifier)), config);
}

std::unique_ptr<TextReader> make_configured_text_reader(const TextReadingConfig& config) {
  if (!config.enabled) return nullptr;
  TextReaderParams params;
  params.engine = config.engine;
  params.tessdata_dir = config.tessdata_dir;
  params.language = config.language;
  params.min_confidence = static_cast<float>(config.min_confidence);
  params.min_long_side = config.min_long_side;
  params.min_word_length = config.min_word_length;
  return make_text_reader(params);
}

}  // namespace keyfleet::station
