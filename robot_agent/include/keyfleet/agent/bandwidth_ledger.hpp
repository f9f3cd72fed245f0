#pragma once
#include <cstdint>
#include <optional>

#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// An agent's byte accounting: what it sent, and what the two baselines (streaming every
// frame, sending every V-SLAM keyframe) would have cost, in serialized sample bytes.
// Baselines are measured on the frames the agent encodes for them and extrapolated to the
// rest; the stats say whether a figure is measured or estimated.
class BandwidthLedger {
 public:
  explicit BandwidthLedger(int baseline_sample_every);

  // Whether the frame with this 0-based index should be encoded for the stream baseline.
  bool should_sample_frame(std::uint64_t frame_number) const;

  void record_frame(std::optional<std::uint64_t> sampled_sample_bytes);
  void record_vslam_keyframe(std::optional<std::uint64_t> sample_bytes);
  void record_sent(std::uint64_t sample_bytes);
  void record_resent(std::uint64_t sample_bytes);
  void record_dropped(std::uint64_t keyframes);

  // Fills the counters of `stats` (identity, time and stage fields are left alone).
  void fill(AgentStats& stats) const;

 private:
  struct Baseline {
    std::uint64_t events = 0;
    std::uint64_t sampled = 0;
    std::uint64_t sampled_bytes = 0;
    std::uint64_t total() const;
    bool estimated() const { return sampled < events; }
  };
  int sample_every_;
  Baseline stream_all_;
  Baseline vslam_;
  std::uint64_t keyframes_sent_ = 0;
  std::uint64_t keyframes_resent_ = 0;
  std::uint64_t keyframes_dropped_ = 0;
  std::uint64_t bytes_sent_ = 0;
  std::uint64_t bytes_resent_ = 0;
};

}  // namespace keyfleet::agent
