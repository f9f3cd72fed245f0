#include <fastdds/dds/log/Log.hpp>

#include <cstdlib>
#include <string>

#include "keyfleet/common/error.hpp"
#include "keyfleet/dds/dds_transport.hpp"

namespace keyfleet {
namespace {

namespace fdds = eprosima::fastdds::dds;

class SpdlogConsumer final : public fdds::LogConsumer {
 public:
  explicit SpdlogConsumer(Logger logger) : logger_(std::move(logger)) {}
  void Consume(const fdds::Log::Entry& entry) override {
    const auto level = entry.kind == fdds::Log::Error     ? spdlog::level::err
                       : entry.kind == fdds::Log::Warning ? spdlog::level::warn
                                                          : spdlog::level::debug;
    logger_->log(level, "[fastdds {}] {}", entry.context.category ? entry.context.category : "",
                 entry.message);
  }

 private:
  Logger logger_;
};

}  // namespace

void route_fastdds_log(Logger logger) {
  fdds::Log::ClearConsumers();
  fdds::Log::RegisterConsumer(std::make_unique<SpdlogConsumer>(std::move(logger)));
  fdds::Log::SetVerbosity(fdds::Log::Warning);
}

void apply_dds_environment(DdsSettings& settings) {
  if (const char* domain = std::getenv("KEYFLEET_DOMAIN"); domain && *domain) {
    char* end = nullptr;
    const long value = std::strtol(domain, &end, 10);
    if (*end != '\0' || value < 0 || value > 232)
      throw StartupError(std::string("KEYFLEET_DOMAIN: must be an integer 0..232, got '") + domain +
                         "'");
    settings.domain_id = static_cast<int>(value);
  }
  if (const char* partition = std::getenv("KEYFLEET_PARTITION"); partition && *partition)
    settings.partition = partition;
}

}  // namespace keyfleet
