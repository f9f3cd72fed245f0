#pragma once
// The YAML description of the station's settings (station_config.hpp), for the configs that
// embed them (a mission's station:): defined and instantiated for the three visitors in
// station_config_yaml.cpp.
#include <string>

#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, StationConfig& c);

// Cross-field rules that a single key cannot express; throws ConfigError naming `origin`.
void validate(const StationConfig& config, const std::string& origin);

}  // namespace keyfleet
