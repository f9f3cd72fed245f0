#pragma once
// The generated part of docs/configuration.md: every key of the agent's and the station's
// config files (a mission's agent: and station:) as Markdown tables (key, type, default,
// allowed), composed from the descriptions in the agent's and the station's libraries.
#include <string>

namespace keyfleet {

std::string config_reference_markdown();

}  // namespace keyfleet
