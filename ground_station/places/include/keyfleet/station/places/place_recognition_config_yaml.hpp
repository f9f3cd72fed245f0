#pragma once
// The YAML description of place recognition's settings (place_recognition_config.hpp), for the
// station's analysis.places: defined and instantiated for the three visitors in
// place_recognition_config_yaml.cpp.
#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/station/places/place_recognition_config.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, PlaceRecognitionConfig& c);

}  // namespace keyfleet
