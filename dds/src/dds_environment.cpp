#include <fastdds/dds/log/Log.hpp>

#include <cstdint>
#include <cstdlib>
#include <iterator>
#include <string>

#include "keyfleet/common/error.hpp"
#include "keyfleet/dds/dds_transport.hpp"

namespace keyfleet {
namespace {

namespace fdds = eprosima::fastdds::dds;

// Warnings Fast DDS repeats for conditions keyfleet expects on a slow link: a capped writer's
// full history (the agent logs each keyframe it could not hand over, "not sent now"), and
// protected submessages that arrive before their sender's keys (reliability repairs them). On a
// 250 kbit/s link they came thousands of times a minute and buried everything else: each is
// logged once as a warning, then counted, with a count every kRepeatEvery times.
constexpr const char* kRepeatedWarnings[] = {"Attempting to add Data to Full WriterCache",
                                             "No key material yet"};
constexpr std::uint64_t kRepeatEvery = 1000;

class SpdlogConsumer final : public fdds::LogConsumer {
 public:
  explicit SpdlogConsumer(Logger logger) : logger_(std::move(logger)) {}
  void Consume(const fdds::Log::Entry& entry) override {
    auto level = entry.kind == fdds::Log::Error     ? spdlog::level::err
                 : entry.kind == fdds::Log::Warning ? spdlog::level::warn
                                                    : spdlog::level::debug;
    const char* category = entry.context.category ? entry.context.category : "";
    for (std::size_t i = 0; i < std::size(kRepeatedWarnings); ++i) {
      if (entry.message.find(kRepeatedWarnings[i]) == std::string::npos) continue;
      const std::uint64_t seen = ++repeats_[i];
      if (seen == 1) {
        logger_->warn("[fastdds {}] {} (expected while a slow link catches up; counted from now)",
                      category, entry.message);
      } else if (seen % kRepeatEvery == 0) {
        logger_->info("[fastdds {}] {} ({} times so far)", category, kRepeatedWarnings[i], seen);
      }
      level = spdlog::level::debug;
    }
    logger_->log(level, "[fastdds {}] {}", category, entry.message);
  }

 private:
  Logger logger_;
  // Fast DDS calls Consume from its one logging thread.
  std::uint64_t repeats_[std::size(kRepeatedWarnings)] = {};
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
