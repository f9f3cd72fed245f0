#pragma once
#include <cstdint>
#include <deque>
#include <map>

namespace keyfleet::agent {

// What the robot's link has delivered lately, from the station's acknowledgements alone (no
// probe traffic). The delivery rate is acknowledged bytes over the time the link was busy, i.e.
// had at least one keyframe handed over and not yet acknowledged: idle time, when the robot had
// nothing to send, says nothing about the link and is not counted, and neither is time without a
// station (pause()), and deliveries older than max_age_s are forgotten (after a long quiet spell
// the rate is learnt anew). The time since the last acknowledgement while busy does count, so a
// link that stops delivering sees its rate fall towards zero instead of keeping an old figure.
struct LinkEstimate {
  double delivery_bytes_per_s = 0;  // 0 when nothing was acknowledged in the window
  double busy_s = 0;                // busy time the rate was taken over
  double rtt_s = 0;                 // smoothed hand-over to acknowledgement, first sends only
  double min_rtt_s = 0;             // the least of the recent ones
  bool known = false;               // the rate means something (see estimate())
  bool from_prior = false;          // nothing measured yet: the rate is the configured prior
};

class LinkEstimator {
 public:
  // window_s: busy seconds the rate is taken over (the newest ones); min_busy_s: busy time
  // before the estimate is known; max_age_s: how long a delivery counts at most.
  explicit LinkEstimator(double window_s = 10.0, double min_busy_s = 1.0, double max_age_s = 30.0);

  // A keyframe's first hand-over to the link (`bytes` serialized).
  void on_sent(std::uint64_t sequence, std::uint64_t bytes, std::int64_t now_ns);
  // Sent again: its acknowledgement may answer either copy, so it gives no round-trip sample.
  void on_resent(std::uint64_t sequence);
  // The station's answer to it, whatever its status; unknown sequences are ignored.
  void on_acked(std::uint64_t sequence, std::int64_t now_ns);
  // No longer awaited (given up on, renumbered): leaves the flight without a delivery.
  void forget(std::uint64_t sequence, std::int64_t now_ns);
  // No station matched: the link is not busy until one is (resume()).
  void pause(std::int64_t now_ns);
  void resume(std::int64_t now_ns);

  // What the link is believed to deliver before anything is measured (e.g. from the radio's
  // configured rate); 0 = no belief: the estimate stays unknown until measured.
  void set_prior(double bytes_per_s) { prior_bytes_per_s_ = bytes_per_s; }

  std::uint64_t bytes_in_flight() const { return in_flight_bytes_; }
  LinkEstimate estimate(std::int64_t now_ns) const;

 private:
  struct Flight {
    std::uint64_t bytes = 0;
    std::int64_t sent_ns = 0;
    bool resent = false;
  };
  struct Segment {  // one stretch between two events
    std::int64_t end_ns = 0;
    double busy_s = 0;
    std::uint64_t acked_bytes = 0;
  };
  bool busy() const { return !paused_ && !flights_.empty(); }
  // Closes the stretch up to now (crediting `acked` bytes to it) before the state changes.
  void close_segment(std::int64_t now_ns, std::uint64_t acked);

  double window_s_;
  double min_busy_s_;
  double max_age_s_;
  double prior_bytes_per_s_ = 0;
  std::map<std::uint64_t, Flight> flights_;
  std::uint64_t in_flight_bytes_ = 0;
  std::deque<Segment> segments_;  // newest last, trimmed to window_s_ of busy time
  double segments_busy_s_ = 0;
  std::int64_t segment_start_ns_ = 0;
  bool paused_ = false;
  double srtt_s_ = 0;
  std::deque<double> recent_rtts_;
};

}  // namespace keyfleet::agent
