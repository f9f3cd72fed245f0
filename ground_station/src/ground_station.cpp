#include "keyfleet/station/ground_station.hpp"

#include "keyfleet/common/clock.hpp"
#include "keyfleet/station/keyframe_validator.hpp"

namespace keyfleet::station {

GroundStation::GroundStation(const StationLimits& limits, KeyframeStore& store, MissionLog& log,
                             StationLink& link, Logger logger,
                             std::shared_ptr<RobotAdmission> admission)
    : limits_(limits),
      store_(store),
      log_(log),
      link_(link),
      logger_(std::move(logger)),
      admission_(admission ? std::move(admission)
                           : std::make_shared<RobotAdmission>(limits, logger_)) {}

void GroundStation::note_robot(const std::string& robot_id) {
  if (!is_valid_robot_id(robot_id) || robots_.count(robot_id)) return;
  robots_.insert(robot_id);
  logger_->info("robot '{}' joined ({} robot(s) so far)", robot_id, robots_.size());
  in_mission_log([&] { log_.event("robot joined: " + robot_id, wall_time_ns()); });
}

// A keyframe whose robot (its writer's, else the one it claims) is not served: rejected without
// a trace in the database, the mission log or the station's maps; counted by the admission.
// A malformed claimed id is left to find_keyframe_problem, which names it.
std::optional<KeyframeAck> GroundStation::refuse_robot(const ReceivedKeyframe& received) {
  const Keyframe& k = received.keyframe;
  const std::string& robot = received.sender.empty() ? k.robot_id : received.sender;
  if (received.sender.empty() && !is_valid_robot_id(robot)) return std::nullopt;
  const RobotAdmission::Verdict verdict = admission_->admit_sample(robot);
  if (verdict == RobotAdmission::Verdict::kAdmitted) return std::nullopt;
  return KeyframeAck{k.robot_id, k.sequence_number, AckStatus::kRejected,
                     "robot '" + printable_text(robot) + "' is not served: " + to_string(verdict)};
}

KeyframeAck GroundStation::handle(const ReceivedKeyframe& received, std::int64_t now_ns) {
  if (auto refused = refuse_robot(received)) return *refused;
  const Keyframe& k = received.keyframe;
  KeyframeAck ack{k.robot_id, k.sequence_number, AckStatus::kStored, {}};
  cv::Mat decoded;
  auto problem = find_keyframe_problem(k, limits_, codec_, &decoded);
  if (!problem && !received.sender.empty() && received.sender != k.robot_id)
    problem = "robot id '" + k.robot_id + "' is not its writer's, '" +
              printable_text(received.sender) + "'";
  if (problem) {
    ack.status = AckStatus::kRejected;
    ack.reason = *problem;
    // The id is recorded as printable text: raw bytes that are not UTF-8 would stop the JSON
    // report and the protobuf mission log from being written.
    const std::string robot = printable_text(k.robot_id);
    if (store_.record_rejection(robot, k.sequence_number, *problem, now_ns)) {
      in_mission_log([&] { log_.rejected(robot, k.sequence_number, *problem, now_ns); });
      logger_->error("rejected keyframe {} from '{}': {}", k.sequence_number, robot, *problem);
    }
    return ack;
  }
  note_robot(k.robot_id);
  // Bad text regions are fixed or dropped, never a reason to refuse the image; the copy is
  // made only then.
  const TextRegionReview review = review_text_regions(
      k.text_regions, k.width, k.height, std::size_t(std::max(0, limits_.max_text_regions)));
  std::optional<Keyframe> fixed;
  if (review.changed()) {
    fixed = k;
    fixed->text_regions = review.regions;
    if (warned_text_regions_.insert(k.robot_id).second)
      logger_->warn(
          "keyframe {} from {}: text regions {} (logged once per robot; the keyframe is kept)",
          k.sequence_number, k.robot_id, review.summary());
  }
  return store_checked(fixed ? *fixed : k, decoded, received.serialized_bytes, now_ns);
}

KeyframeAck GroundStation::store_checked(const Keyframe& k, const cv::Mat& decoded,
                                         std::uint64_t serialized_bytes, std::int64_t now_ns) {
  KeyframeAck ack{k.robot_id, k.sequence_number, AckStatus::kStored, {}};
  const StoreOutcome outcome = store_.store(k, serialized_bytes, now_ns);
  if (outcome == StoreOutcome::kConflict) {
    ack.status = AckStatus::kConflict;
    ack.reason = "sequence " + std::to_string(k.sequence_number) +
                 " is already stored with another image; this one is kept apart";
    logger_->error("keyframe {} from {}: {} (the robot lost its sequence numbers?)",
                   k.sequence_number, k.robot_id, ack.reason);
    in_mission_log([&] {
      log_.event("sequence conflict: " + k.robot_id + " " + std::to_string(k.sequence_number),
                 now_ns);
    });
    return ack;
  }
  if (outcome == StoreOutcome::kDuplicate) {
    ack.status = AckStatus::kDuplicate;
    logger_->debug("duplicate keyframe {} from {} acknowledged again", k.sequence_number,
                   k.robot_id);
    return ack;
  }
  // Stored in the database: acknowledged whatever happens to the mission log's line about it.
  if (on_stored_) on_stored_(k, decoded);
  in_mission_log([&] { log_.keyframe(k, serialized_bytes, now_ns); });
  logger_->debug("stored keyframe {} from {} ({} bytes)", k.sequence_number, k.robot_id,
                 serialized_bytes);
  return ack;
}

void GroundStation::handle(const AgentStats& stats) {
  if (!is_valid_robot_id(stats.robot_id)) {
    logger_->error("ignored agent stats with a malformed robot id '{}'",
                   stats.robot_id.substr(0, 64));
    return;
  }
  if (admission_->admit_sample(stats.robot_id) != RobotAdmission::Verdict::kAdmitted) return;
  note_robot(stats.robot_id);
  store_.record_stats(stats);
  in_mission_log([&] { log_.agent_stats(stats); });
}

void GroundStation::in_mission_log(const std::function<void()>& write) {
  try {
    write();
  } catch (const std::exception& e) {
    if (mission_log_failures_++ % 100 == 0)
      logger_->error("mission log: {} ({} record(s) not written so far; the database has them)",
                     e.what(), mission_log_failures_);
  }
}

void GroundStation::storage_failed(const std::string& what, const char* error) {
  // Said once when it starts failing, then every 100th time: a full disk fails every write.
  if (storage_failures_++ % 100 == 0)
    logger_->error(
        "could not store {} ({} failed write(s) in a row): {}; nothing is acknowledged until "
        "storage works again, the robots keep their copies and resend",
        what, storage_failures_, error);
}

void GroundStation::storage_worked() {
  if (storage_failures_ == 0) return;
  logger_->info("storage works again after {} failed write(s)", storage_failures_);
  storage_failures_ = 0;
}

std::size_t GroundStation::step(std::chrono::milliseconds wait) {
  StationInbox inbox = link_.take(wait, 64);
  for (const auto& stats : inbox.stats) {
    try {
      handle(stats);
    } catch (const std::exception& e) {
      // Statistics are cumulative: the robot's next report carries what this one said.
      storage_failed("the statistics of '" + printable_text(stats.robot_id) + "'", e.what());
    }
  }
  for (const auto& received : inbox.keyframes) {
    KeyframeAck ack;
    try {
      ack = handle(received, wall_time_ns());
    } catch (const std::exception& e) {
      // Not acknowledged, so the agent resends.
      storage_failed("keyframe " + std::to_string(received.keyframe.sequence_number) + " from '" +
                         printable_text(received.keyframe.robot_id) + "'",
                     e.what());
      continue;
    }
    storage_worked();
    const PublishResult sent = link_.acknowledge(ack);
    if (!sent.ok) logger_->warn("acknowledgement not sent ({}); the agent will resend", sent.error);
  }
  return inbox.keyframes.size();
}

}  // namespace keyfleet::station
