#pragma once
// Which robots the station serves: with DDS-Security on, those the fleet's roster lists (the ids
// `keyfleet security init` issued identities for, less those withdrawn), so that an id without
// an identity never takes a slot; of those, the ones on limits.allowed_robots (anyone when it is
// empty), at most limits.max_robots of them, first come first served. So that a peer inventing
// robot ids cannot make the station grow its readers, tables and maps without end.
#include <cstdint>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/security_files.hpp"

namespace keyfleet {

// What the station refused for the robot's sake, for its report.
struct RobotRefusals {
  std::uint64_t no_identity = 0;  // distinct ids not on the fleet's roster (security on)
  std::uint64_t withdrawn = 0;    // distinct ids withdrawn from the fleet (security on)
  std::uint64_t not_allowed = 0;  // distinct ids not on allowed_robots
  std::uint64_t over_quota = 0;   // distinct ids refused because max_robots were served
  std::uint64_t malformed = 0;    // distinct ids outside [A-Za-z0-9_-]{1,32}
  std::uint64_t samples = 0;      // keyframe and stats samples refused for their robot
  std::vector<std::string> ids;   // the first refused ids (printable), at most kListedIds
  static constexpr std::size_t kListedIds = 16;
  bool any() const {
    return no_identity + withdrawn + not_allowed + over_quota + malformed + samples > 0;
  }
};

// Thread-safe: the DDS link asks from Fast DDS's discovery thread, the station from its loop.
class RobotAdmission {
 public:
  enum class Verdict { kAdmitted, kNoIdentity, kWithdrawn, kNotAllowed, kOverQuota, kMalformed };

  // `roster`: the fleet's (security on), or none (security off: any id may ask).
  RobotAdmission(const StationLimits& limits, Logger logger,
                 std::optional<FleetRoster> roster = std::nullopt);

  // Admits `robot_id` when it is allowed and the quota has room (an admitted id stays admitted).
  // The first refusal of each id is logged once and counted.
  Verdict admit(const std::string& robot_id);
  // admit(), and a refusal counted as one refused sample.
  Verdict admit_sample(const std::string& robot_id);

  RobotRefusals refusals() const;
  std::size_t admitted_count() const;

  // Refused ids remembered (each logged and counted once); beyond it, every refusal of an id not
  // remembered counts again and is not logged: the memory of strangers is bounded too.
  static constexpr std::size_t kRememberedRefusals = 1024;

 private:
  Verdict decide(const std::string& robot_id) const;
  void note_refusal(const std::string& robot_id, Verdict verdict);

  std::optional<FleetRoster> roster_;
  std::set<std::string> allowed_;
  std::size_t max_robots_;
  Logger logger_;
  mutable std::mutex mutex_;
  std::set<std::string> admitted_;
  std::set<std::string> refused_;
  RobotRefusals refusals_;
  bool warned_forgetting_ = false;
};

std::string to_string(RobotAdmission::Verdict verdict);

}  // namespace keyfleet
