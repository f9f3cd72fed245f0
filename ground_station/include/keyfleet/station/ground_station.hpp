#pragma once
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <set>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/robot_admission.hpp"
#include "keyfleet/common/transport.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/mission_log.hpp"

namespace keyfleet::station {

// The station's per-message work as synchronous steps: validate, store exactly once,
// log, acknowledge. Bad samples are rejected with a reason and never stop it.
//
// Threads: everything here runs on the thread that calls step() (the station's main loop).
// Fast DDS's own threads only receive samples into the readers' bounded histories and hear
// writers being discovered (the link's one listener, which asks `admission` whether to read a
// robot's topics); step() takes the samples, inspects each JPEG's markers and bounds its cost
// (find_keyframe_problem) before the one decode, stores and acknowledges. The heavier analysis
// runs later on AnalysisPool's workers.
class GroundStation {
 public:
  // `admission` decides which robots are served; shared with the link (null: one of its own,
  // from `limits`).
  GroundStation(const StationLimits& limits, KeyframeStore& store, MissionLog& log,
                StationLink& link, Logger logger,
                std::shared_ptr<RobotAdmission> admission = nullptr);

  KeyframeAck handle(const ReceivedKeyframe& received, std::int64_t now_ns);
  void handle(const AgentStats& stats);
  // Takes what the link has (waiting up to `wait`), handles and acknowledges it.
  // Returns the number of keyframes handled.
  std::size_t step(std::chrono::milliseconds wait);

  const std::set<std::string>& robots() const { return robots_; }
  // Writes that failed since storage last worked (a full disk, an I/O error); while it is
  // above 0 nothing is acknowledged and the robots keep their copies.
  std::size_t storage_failures() const { return storage_failures_; }
  const RobotAdmission& admission() const { return *admission_; }
  // Called once per keyframe newly stored (not for duplicates or rejections), after commit, with
  // the pixels its check decoded.
  using StoredCallback = std::function<void(const Keyframe&, const cv::Mat& decoded)>;
  void on_stored(StoredCallback callback) { on_stored_ = std::move(callback); }

 private:
  void note_robot(const std::string& robot_id);
  std::optional<KeyframeAck> refuse_robot(const ReceivedKeyframe& received);
  KeyframeAck store_checked(const Keyframe& keyframe, const cv::Mat& decoded,
                            std::uint64_t serialized_bytes, std::int64_t now_ns);
  void storage_failed(const std::string& what, const char* error);
  // Runs a mission-log write; a failure is said (once, then every 100th) and not thrown: the
  // database, not the log, is what acknowledgements promise.
  void in_mission_log(const std::function<void()>& write);
  void storage_worked();

  StationLimits limits_;
  KeyframeStore& store_;
  MissionLog& log_;
  StationLink& link_;
  Logger logger_;
  std::shared_ptr<RobotAdmission> admission_;
  JpegCodec codec_{90};
  std::set<std::string> robots_;
  std::set<std::string> warned_text_regions_;  // robots whose bad text regions were logged
  StoredCallback on_stored_;
  std::size_t storage_failures_ = 0;
  std::size_t mission_log_failures_ = 0;
};

}  // namespace keyfleet::station
