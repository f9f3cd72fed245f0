#pragma once
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/link_estimator.hpp"

namespace keyfleet::agent {

// One rung of the ladder, richest first.
struct SendLevel {
  int jpeg_quality = 85;
  double scale = 1.0;
  int density = 1;
  bool operator==(const SendLevel& o) const {
    return jpeg_quality == o.jpeg_quality && scale == o.scale && density == o.density;
  }
};

// codec.jpeg_quality first, then the config's steps in order.
std::vector<SendLevel> send_ladder(const LinkAdaptationConfig& config, int jpeg_quality);
std::string describe(const SendLevel& level);

struct LevelChange {
  std::size_t from = 0, to = 0;
  std::string reason;
};

// Chooses the ladder's rung from the link's estimate, the backlog and what keyframes cost. Pure:
// times come in as arguments, so traces can be replayed in tests.
class SendController {
 public:
  SendController(const LinkAdaptationConfig& config, int jpeg_quality);

  const std::vector<SendLevel>& ladder() const { return ladder_; }
  std::size_t level_index() const { return level_; }
  const SendLevel& level() const { return ladder_[level_]; }

  // A selection made at now_ns (whether or not it is sent at once).
  void on_selection(std::int64_t now_ns);
  // Serialized bytes of keyframes encoded at each level (a calibration encodes one frame at
  // every level; a publication reports the one used). Costs learnt for one level carry over to
  // the others in proportion until those are measured.
  void on_cost(std::size_t level, std::uint64_t bytes);
  // Whether the selection now being made goes at once (density: one in level().density).
  bool send_now();

  // The rung for what comes next; a change is returned with its reason (for the log).
  std::optional<LevelChange> update(std::int64_t now_ns, const LinkEstimate& link,
                                    std::uint64_t backlog_bytes);

  // Expected wait of the backlog at the estimated rate, seconds (infinite when the link has
  // delivered nothing lately; 0 when the rate is not known yet).
  static double backlog_wait_s(const LinkEstimate& link, std::uint64_t backlog_bytes);
  // Bytes per second the level would offer at the recent selection rate.
  double offered_bytes_per_s(std::size_t level) const;
  // Bytes one keyframe costs at the level: measured, else scaled from the nearest measured
  // level by the JPEG model; 0 before anything was measured.
  double keyframe_bytes(std::size_t level) const;
  // Selections a second over the last 30 s (0 before the second one).
  double selections_per_s() const;

 private:
  std::size_t richest_fitting(double budget_bytes_per_s) const;

  LinkAdaptationConfig config_;
  std::vector<SendLevel> ladder_;
  std::vector<double> cost_;  // bytes of one keyframe at each level; 0 = not known
  std::size_t level_ = 0;
  std::int64_t now_ns_ = 0;  // the latest time seen
  std::int64_t last_change_ns_ = 0;
  std::int64_t room_since_ns_ = -1;  // the richer level has fitted since (-1: it has not)
  std::deque<std::int64_t> selections_;
  std::uint64_t density_counter_ = 0;
};

}  // namespace keyfleet::agent
