#include "keyfleet/station/analysis_setup.hpp"

#include "keyfleet/vision/model_files.hpp"

namespace keyfleet::station {

std::unique_ptr<PlaceRecognizer> make_configured_place_recognizer(
    const PlaceRecognitionConfig& config) {
  if (!config.enabled) return nullptr;
  auto vocabulary = std::make_shared<const OrbVocabulary>(OrbVocabulary::load(
      vision::locate_model(config.vocabulary, "place recognition: vocabulary")));
  return std::make_unique<OrbBowPlaceRecognizer>(std::move(vocabulary),
                                                 make_match_verifier(config.verifier), config);
}

std::unique_ptr<TextReader> make_configured_text_reader(const TextReadingConfig& config) {
  if (!config.enabled) return nullptr;
  return make_text_reader(config);
}

}  // namespace keyfleet::station
