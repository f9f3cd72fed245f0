#pragma once
// The YAML description of the text reader's settings (text_reading_config.hpp), for the configs
// that embed it (the station's analysis.text, `keyfleet eval`'s text:): defined and instantiated
// for the three visitors in text_reading_config_yaml.cpp.
#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/station/text/text_reading_config.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, TextReadingConfig& c);

}  // namespace keyfleet
