#pragma once
#include <memory>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/place_recognizer.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"
#include "keyfleet/vision/place_describer.hpp"

namespace keyfleet::station {

// The real engines the station's configuration names. nullptr when that part is disabled;
// StartupError when a file (vocabulary, OCR data) is missing or unusable.
std::unique_ptr<PlaceRecognizer> make_configured_place_recognizer(
    const PlaceRecognitionConfig& config);
// The holistic descriptor model where the retrieval uses it (cnn, fusion); nullptr otherwise.
// One per thread that describes.
std::unique_ptr<vision::PlaceDescriber> make_configured_place_describer(
    const PlaceRecognitionConfig& config);
std::unique_ptr<TextReader> make_configured_text_reader(const TextReadingConfig& config);
// The station's own: the same, or where the engine's fetched models are missing
// (EngineModelsMissing) and `config.fallback_engine` names another engine, that one, with one
// warning naming the missing file. `config.engine` then names the engine that reads, so the next
// worker's reader starts it without a second warning.
std::unique_ptr<TextReader> make_station_text_reader(TextReadingConfig& config,
                                                     const Logger& logger);

}  // namespace keyfleet::station
