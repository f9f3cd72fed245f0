#pragma once
// The YAML descriptions of the agent's settings (agent_config.hpp) that other configs embed (a
// mission's agent:, `keyfleet eval`'s selector: and codec:): defined and instantiated for the
// three visitors in agent_config_yaml.cpp.
#include <string>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/config_yaml.hpp"

namespace keyfleet {

template <class V>
void visit(V& v, AgentConfig& c);
template <class V>
void visit(V& v, SelectorConfig& c);
template <class V>
void visit(V& v, CodecConfig& c);

// Cross-field rules that a single key cannot express; throws ConfigError naming `origin`.
void validate(const AgentConfig& config, const std::string& origin);

}  // namespace keyfleet
