#pragma once
#include <memory>

#include "keyfleet/common/config.hpp"
#include "keyfleet/station/place_recognizer.hpp"
#include "keyfleet/station/text/text_reader.hpp"

namespace keyfleet::station {

// The real engines the station's configuration names. nullptr when that part is disabled;
// StartupError when a file (vocabulary, OCR data) is missing or unusable.
std::unique_ptr<PlaceRecognizer> make_configured_place_recognizer(
    const PlaceRecognitionConfig& config);
std::unique_ptr<TextReader> make_configured_text_reader(const TextReadingConfig& config);

}  // namespace keyfleet::station
