// BandwidthLedger: measured versus extrapolated baselines and the counters in AgentStats.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <stdexcept>

#include "keyfleet/agent/bandwidth_ledger.hpp"

namespace keyfleet::agent {
namespace {

// Records `frames` frames the way the agent does: a size only for the sampled ones.
// Returns the exact sum of all frame sizes (what a perfect measurement would give).
std::uint64_t record_frames(BandwidthLedger& ledger, std::uint64_t frames,
                            std::uint64_t (*size_of)(std::uint64_t)) {
  std::uint64_t exact = 0;
  for (std::uint64_t i = 0; i < frames; ++i) {
    exact += size_of(i);
    ledger.record_frame(ledger.should_sample_frame(i) ? std::optional(size_of(i)) : std::nullopt);
  }
  return exact;
}

std::uint64_t growing_size(std::uint64_t i) { return 1000 + 10 * i; }

TEST(BandwidthLedger, RejectsSampleEveryBelowOne) {
  EXPECT_THROW(BandwidthLedger(0), std::invalid_argument);
  EXPECT_THROW(BandwidthLedger(-1), std::invalid_argument);
}

TEST(BandwidthLedger, SamplesEveryNthFrameStartingAtZero) {
  const BandwidthLedger ledger(10);
  EXPECT_TRUE(ledger.should_sample_frame(0));
  for (std::uint64_t i = 1; i < 10; ++i) EXPECT_FALSE(ledger.should_sample_frame(i)) << i;
  EXPECT_TRUE(ledger.should_sample_frame(10));
  EXPECT_TRUE(ledger.should_sample_frame(990));
  EXPECT_FALSE(ledger.should_sample_frame(991));
}

TEST(BandwidthLedger, SamplingEveryFrameGivesExactNonEstimatedTotals) {
  BandwidthLedger ledger(1);
  const std::uint64_t exact = record_frames(ledger, 25, growing_size);
  ledger.record_vslam_keyframe(700);
  ledger.record_vslam_keyframe(900);

  AgentStats stats;
  ledger.fill(stats);
  EXPECT_EQ(stats.frames_seen, 25u);
  EXPECT_EQ(stats.stream_all_bytes, exact);
  EXPECT_FALSE(stats.stream_all_estimated);
  EXPECT_EQ(stats.stream_all_sampled_frames, 25u);
  EXPECT_EQ(stats.vslam_keyframes, 2u);
  EXPECT_EQ(stats.vslam_keyframe_bytes, 1600u);
  EXPECT_FALSE(stats.vslam_keyframe_estimated);
}

TEST(BandwidthLedger, SparseSamplingExtrapolatesMeanTimesEventsAndSaysEstimated) {
  BandwidthLedger ledger(10);
  record_frames(ledger, 100, growing_size);  // samples frames 0, 10, ..., 90

  std::uint64_t sampled_sum = 0;
  for (std::uint64_t i = 0; i < 100; i += 10) sampled_sum += growing_size(i);
  const double mean = static_cast<double>(sampled_sum) / 10.0;

  AgentStats stats;
  ledger.fill(stats);
  EXPECT_EQ(stats.frames_seen, 100u);
  EXPECT_EQ(stats.stream_all_sampled_frames, 10u);
  EXPECT_TRUE(stats.stream_all_estimated);
  EXPECT_EQ(stats.stream_all_bytes, static_cast<std::uint64_t>(mean * 100.0));
}

TEST(BandwidthLedger, ExtrapolationRoundsToNearestByte) {
  BandwidthLedger ledger(2);
  ledger.record_frame(1001);  // frame 0 sampled
  ledger.record_frame(std::nullopt);
  ledger.record_frame(1002);  // frame 2 sampled; mean 1001.5 over 3 frames = 3004.5
  AgentStats stats;
  ledger.fill(stats);
  EXPECT_TRUE(stats.stream_all_estimated);
  EXPECT_NEAR(static_cast<double>(stats.stream_all_bytes), 3004.5, 0.5);
}

TEST(BandwidthLedger, VslamBaselineIsEstimatedWhenSomeKeyframesWereNotMeasured) {
  BandwidthLedger ledger(1);
  ledger.record_vslam_keyframe(400);
  ledger.record_vslam_keyframe(std::nullopt);
  ledger.record_vslam_keyframe(600);
  ledger.record_vslam_keyframe(std::nullopt);
  AgentStats stats;
  ledger.fill(stats);
  EXPECT_EQ(stats.vslam_keyframes, 4u);
  EXPECT_TRUE(stats.vslam_keyframe_estimated);
  EXPECT_EQ(stats.vslam_keyframe_bytes, 2000u);
}

TEST(BandwidthLedger, NothingRecordedGivesZeroTotals) {
  const BandwidthLedger ledger(10);
  AgentStats stats;
  stats.stream_all_bytes = 99;
  ledger.fill(stats);
  EXPECT_EQ(stats.frames_seen, 0u);
  EXPECT_EQ(stats.stream_all_bytes, 0u);
  EXPECT_EQ(stats.vslam_keyframe_bytes, 0u);
  EXPECT_EQ(stats.keyframes_sent, 0u);
}

TEST(BandwidthLedger, SentResentAndDroppedCountersFlowToAgentStats) {
  BandwidthLedger ledger(10);
  ledger.record_sent(100);
  ledger.record_sent(250);
  ledger.record_sent(0);  // a publish that failed still counts as a keyframe sent
  ledger.record_resent(80);
  ledger.record_resent(20);
  ledger.record_dropped(3);
  ledger.record_dropped(2);

  AgentStats stats;
  ledger.fill(stats);
  EXPECT_EQ(stats.keyframes_sent, 3u);
  EXPECT_EQ(stats.bytes_sent, 350u);
  EXPECT_EQ(stats.keyframes_resent, 2u);
  EXPECT_EQ(stats.bytes_resent, 100u);
  EXPECT_EQ(stats.keyframes_dropped, 5u);
}

TEST(BandwidthLedger, FillLeavesIdentityTimeAndStageFieldsAlone) {
  BandwidthLedger ledger(1);
  ledger.record_frame(10);
  AgentStats stats;
  stats.robot_id = "drone_4";
  stats.report_time_ns = 123456789;
  stats.finished = true;
  stats.keyframes_pending = 7;
  stats.stages = {{"encode", 1.5, 3}};
  ledger.fill(stats);
  EXPECT_EQ(stats.robot_id, "drone_4");
  EXPECT_EQ(stats.report_time_ns, 123456789);
  EXPECT_TRUE(stats.finished);
  EXPECT_EQ(stats.keyframes_pending, 7u);
  ASSERT_EQ(stats.stages.size(), 1u);
  EXPECT_EQ(stats.stages[0].stage, "encode");
  EXPECT_EQ(stats.frames_seen, 1u);
}

}  // namespace
}  // namespace keyfleet::agent
