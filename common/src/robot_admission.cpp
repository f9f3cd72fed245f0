#include "keyfleet/common/robot_admission.hpp"

#include "keyfleet/common/printable_text.hpp"

namespace keyfleet {

RobotAdmission::RobotAdmission(const StationLimits& limits, Logger logger,
                               std::optional<FleetRoster> roster)
    : roster_(std::move(roster)),
      allowed_(limits.allowed_robots.begin(), limits.allowed_robots.end()),
      max_robots_(static_cast<std::size_t>(limits.max_robots)),
      logger_(std::move(logger)) {}

RobotAdmission::Verdict RobotAdmission::decide(const std::string& robot_id) const {
  if (admitted_.count(robot_id)) return Verdict::kAdmitted;
  if (!is_valid_robot_id(robot_id)) return Verdict::kMalformed;
  if (roster_ && roster_->withdrawn.count(robot_id)) return Verdict::kWithdrawn;
  if (roster_ && !roster_->has(robot_id)) return Verdict::kNoIdentity;
  if (!allowed_.empty() && !allowed_.count(robot_id)) return Verdict::kNotAllowed;
  if (admitted_.size() >= max_robots_) return Verdict::kOverQuota;
  return Verdict::kAdmitted;
}

RobotAdmission::Verdict RobotAdmission::admit(const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const Verdict verdict = decide(robot_id);
  if (verdict == Verdict::kAdmitted)
    admitted_.insert(robot_id);
  else
    note_refusal(robot_id, verdict);
  return verdict;
}

RobotAdmission::Verdict RobotAdmission::admit_sample(const std::string& robot_id) {
  const Verdict verdict = admit(robot_id);
  if (verdict != Verdict::kAdmitted) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++refusals_.samples;
  }
  return verdict;
}

void RobotAdmission::note_refusal(const std::string& robot_id, Verdict verdict) {
  const std::string shown = printable_text(robot_id, 64);
  if (refused_.count(shown)) return;
  if (refused_.size() < kRememberedRefusals) {
    refused_.insert(shown);
    const std::string quota =
        verdict == Verdict::kOverQuota ? " (" + std::to_string(max_robots_) + ")" : "";
    logger_->warn(
        "robot '{}' refused: {}{}; its topics are not read and its samples are rejected (logged "
        "once per robot)",
        shown, to_string(verdict), quota);
  } else if (!warned_forgetting_) {
    warned_forgetting_ = true;
    logger_->error("more than {} robot ids refused: further ones are counted, not logged",
                   kRememberedRefusals);
  }
  if (verdict == Verdict::kNoIdentity) ++refusals_.no_identity;
  if (verdict == Verdict::kWithdrawn) ++refusals_.withdrawn;
  if (verdict == Verdict::kNotAllowed) ++refusals_.not_allowed;
  if (verdict == Verdict::kOverQuota) ++refusals_.over_quota;
  if (verdict == Verdict::kMalformed) ++refusals_.malformed;
  if (refusals_.ids.size() < RobotRefusals::kListedIds) refusals_.ids.push_back(shown);
}

RobotRefusals RobotAdmission::refusals() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return refusals_;
}

std::size_t RobotAdmission::admitted_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return admitted_.size();
}

std::string to_string(RobotAdmission::Verdict verdict) {
  switch (verdict) {
    case RobotAdmission::Verdict::kAdmitted: return "admitted";
    case RobotAdmission::Verdict::kNoIdentity:
      return "no identity in the fleet (not on the roster of `keyfleet security init`)";
    case RobotAdmission::Verdict::kWithdrawn: return "withdrawn from the fleet";
    case RobotAdmission::Verdict::kNotAllowed: return "not on limits.allowed_robots";
    case RobotAdmission::Verdict::kOverQuota: return "limits.max_robots robots are served already";
    case RobotAdmission::Verdict::kMalformed: return "not a robot id ([A-Za-z0-9_-]{1,32})";
  }
  return "?";
}

}  // namespace keyfleet
