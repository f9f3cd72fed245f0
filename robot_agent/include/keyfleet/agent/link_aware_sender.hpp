#pragma once
#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <vector>

#include "keyfleet/agent/link_estimator.hpp"
#include "keyfleet/agent/send_controller.hpp"
#include "keyfleet/common/config.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// The agent's link-aware sending: the estimator fed with what the agent hands over and what the
// station acknowledges, the controller's level, and the frame encoded at that level (JPEG
// quality, then the frame scaled down, or with text_aware only its background: level_encoding.hpp).
// With adaptation
// off it only estimates the link, and every keyframe goes at the richest level.
// The sample bytes a second a radio link of this profile is believed to carry before the agent
// has measured it: the configured rate and pacing, less the RTPS, UDP, IP and security headers
// around MTU-sized messages (a third more on the wire, as measured on the emulated links). 0 for
// a link without a rate (a LAN, one machine).
double link_prior_bytes_per_s(const DdsLinkProfile& link);

class LinkAwareSender {
 public:
  // prior_bytes_per_s: what the link is believed to deliver until measured (0: nothing);
  // backlog_bytes: what waits unacknowledged (the outbox's pending_bytes), asked only when a
  // decision or the stats need it.
  LinkAwareSender(const LinkAdaptationConfig& config, const ImageCodec& codec, int jpeg_quality,
                  double prior_bytes_per_s, std::function<std::uint64_t()> backlog_bytes,
                  Logger logger);

  struct Encoded {
    std::vector<std::uint8_t> image;
    std::uint32_t width = 0, height = 0;
    std::vector<TextRegion> text_regions;  // in the encoded image's pixels
    bool reduced = false;                  // below the richest level
    bool held = false;                     // thinned: waits in the outbox behind the rest
  };
  // One selection: the level now, and the frame at it. `richest` gives the frame encoded at the
  // richest level (the agent's cached encoding).
  Encoded encode(const cv::Mat& frame, const std::vector<TextRegion>& regions, std::int64_t now_ns,
                 const std::function<const std::vector<std::uint8_t>&()>& richest);

  void on_sent(std::uint64_t sequence, std::uint64_t bytes, std::int64_t now_ns) {
    estimator_.on_sent(sequence, bytes, now_ns);
  }
  void on_resent(std::uint64_t sequence) { estimator_.on_resent(sequence); }
  void on_acked(std::uint64_t sequence, std::int64_t now_ns) {
    estimator_.on_acked(sequence, now_ns);
  }
  void forget(std::uint64_t sequence, std::int64_t now_ns) { estimator_.forget(sequence, now_ns); }
  void station_matched(bool matched, std::int64_t now_ns);
  // Lets the level follow the link between selections (with adaptation on, at most every
  // 200 ms).
  void update(std::int64_t now_ns);
  // Held keyframes go when the backlog would wait under a quarter of the target (as of the last
  // update; never with adaptation off, which holds nothing).
  bool room_for_held() const { return room_for_held_; }

  void fill(AgentStats& stats, std::int64_t now_ns) const;

 private:
  void apply(std::int64_t now_ns);
  // Every distinct encoding of the ladder, measured on this frame, teaches the controller.
  void calibrate(const cv::Mat& frame, const std::vector<TextRegion>& regions);

  LinkAdaptationConfig config_;
  const ImageCodec& codec_;
  Logger logger_;
  LinkEstimator estimator_;
  SendController controller_;
  std::function<std::uint64_t()> backlog_bytes_;
  bool room_for_held_ = false;
  std::int64_t last_update_ns_ = 0;
  std::uint64_t selections_ = 0;
  std::uint64_t reduced_ = 0;
  std::uint64_t thinned_ = 0;
  std::uint64_t level_changes_ = 0;
};

}  // namespace keyfleet::agent
