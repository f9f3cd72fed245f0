#pragma once
#include <spdlog/spdlog.h>

#include <memory>
#include <string>

namespace keyfleet {

using Logger = std::shared_ptr<spdlog::logger>;

// A logger writing to stderr (and to `file` when given). Libraries never create loggers:
// executables make them here and inject them. Throws StartupError on a bad level name.
Logger make_logger(const std::string& name, const std::string& level, const std::string& file = "");

// A logger that discards everything, for tests and optional diagnostics.
Logger null_logger();

}  // namespace keyfleet
