#pragma once
#include "keyfleet/common/error.hpp"

namespace keyfleet {

// A configuration problem: the message names the file, the line, the key and what is allowed.
class ConfigError : public StartupError {
 public:
  using StartupError::StartupError;
};

}  // namespace keyfleet
