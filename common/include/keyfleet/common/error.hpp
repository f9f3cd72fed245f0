#pragma once
#include <stdexcept>
#include <string>

namespace keyfleet {

// Start-up errors (bad config, missing file, unusable model): thrown by libraries,
// reported once by the executable's main with a non-zero exit.
class StartupError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace keyfleet
