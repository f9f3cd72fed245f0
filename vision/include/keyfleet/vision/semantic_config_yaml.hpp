#pragma once
// The YAML description of the text segmenter's settings (semantic_config.hpp), for the agent's
// selector section that embeds it: defined and instantiated for the three visitors in
// semantic_config_yaml.cpp.
#include "keyfleet/common/config_yaml.hpp"
#include "keyfleet/vision/semantic_config.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, SemanticConfig& c);

}  // namespace keyfleet
