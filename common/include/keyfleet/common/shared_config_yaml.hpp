#pragma once
// The YAML descriptions of the settings both sides read (config.hpp), for the agent's and the
// station's descriptions that embed them: defined and instantiated for the three visitors in
// shared_config_yaml.cpp.
#include <string>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, DdsSettings& c);
template <class V>
void visit(V& v, StationLimits& c);

// dds.security.directory is required when dds.security.enabled; throws ConfigError naming
// `origin`.
void validate(const DdsSettings& dds, const std::string& origin);

}  // namespace keyfleet
