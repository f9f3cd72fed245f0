#include "keyfleet/station/analysis_setup.hpp"

#include "keyfleet/vision/model_files.hpp"

namespace keyfleet::station {

std::unique_ptr<PlaceRecognizer> make_configured_place_recognizer(
    const PlaceRecognitionConfig& config) {
  if (!config.enabled) return nullptr;
  auto vocabulary = std::make_shared<const OrbVocabulary>(OrbVocabulary::load(
      vision::locate_model(config.vocabulary, "place recognition: vocabulary")));
  const int dimensions =
      !retrieval_mode(config.retrieval).ranks_by_descriptor()
          ? 0
          : vision::read_place_describer_info(
                vision::locate_model(config.descriptor, "place recognition: descriptor model"))
                .dimensions;
  return std::make_unique<VerifiedPlaceRecognizer>(
      std::move(vocabulary), make_match_verifier(config.verifier), config, dimensions);
}

std::unique_ptr<vision::PlaceDescriber> make_configured_place_describer(
    const PlaceRecognitionConfig& config) {
  if (!config.enabled || !retrieval_mode(config.retrieval).ranks_by_descriptor()) return nullptr;
  return std::make_unique<vision::DnnPlaceDescriber>(
      vision::locate_model(config.descriptor, "place recognition: descriptor model"));
}

std::unique_ptr<TextReader> make_configured_text_reader(const TextReadingConfig& config) {
  if (!config.enabled) return nullptr;
  return make_text_reader(config);
}

std::unique_ptr<TextReader> make_station_text_reader(TextReadingConfig& config,
                                                     const Logger& logger) {
  try {
    return make_configured_text_reader(config);
  } catch (const EngineModelsMissing& e) {
    if (config.fallback_engine.empty() || config.fallback_engine == config.engine) throw;
    logger->warn(
        "text reading: {}; reading with '{}' instead (analysis.text.fallback_engine; empty "
        "refuses to start)",
        e.what(), config.fallback_engine);
    config.engine = config.fallback_engine;
    return make_configured_text_reader(config);
  }
}

}  // namespace keyfleet::station
