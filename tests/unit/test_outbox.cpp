// The agent's durable outbox: sequencing, persistence, resends and eviction bounds.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/common/error.hpp"
#include "test_support.hpp"

namespace keyfleet::agent {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kStart = 1'700'000'000 * kSecond;

OutboxConfig bounds(double resend_after_s = 2.0, std::uint64_t max_pending = 1000,
                    double max_age_s = 3600.0) {
  OutboxConfig c;
  c.resend_after_s = resend_after_s;
  c.max_pending = max_pending;
  c.max_age_s = max_age_s;
  return c;
}

// A keyframe with distinctive values in every field, and an image holding every byte value.
Keyframe distinctive_keyframe(const std::string& robot_id, std::uint64_t sequence) {
  Keyframe k;
  k.robot_id = robot_id;
  k.sequence_number = sequence;
  k.frame_index = 1000 + sequence;
  k.capture_time_ns = kStart + static_cast<std::int64_t>(sequence) * 33'333'333;
  k.vslam_keyframe_index = 50 + sequence;
  k.window_first_frame = 990 + sequence;
  k.window_last_frame = 1010 + sequence;
  k.quality_score = 0.123456789 + static_cast<double>(sequence);
  k.sharpness_score = 987.654321;
  k.semantic_score = -0.5;
  k.encoding = "jpeg";
  k.width = 640;
  k.height = 480;
  k.image = keyfleet::test::random_bytes(3000, static_cast<unsigned>(sequence) + 1);
  for (int b = 0; b < 256; ++b) k.image.push_back(static_cast<std::uint8_t>(b));
  k.camera_pose = Pose{1.0 + static_cast<double>(sequence), -2.5, 3.25, 0.1, 0.2, 0.3, 0.9};
  return k;
}

std::vector<std::uint64_t> sequences(const std::vector<Keyframe>& keyframes) {
  std::vector<std::uint64_t> out;
  for (const auto& k : keyframes) out.push_back(k.sequence_number);
  return out;
}

void add_sent(Outbox& outbox, const std::string& robot, std::int64_t now_ns) {
  const std::uint64_t sequence = outbox.next_sequence();
  outbox.add(distinctive_keyframe(robot, sequence), now_ns);
  outbox.mark_sent(sequence, now_ns);
}

class OutboxTest : public ::testing::Test {
 protected:
  keyfleet::test::TempDir dir_;
  std::string path_ = dir_.file("outbox.sqlite");
};

TEST_F(OutboxTest, NewOutboxStartsAtSequenceZeroAndEmpty) {
  const Outbox outbox(path_, "drone_0", bounds());
  EXPECT_EQ(outbox.next_sequence(), 0u);
  EXPECT_EQ(outbox.pending(), 0u);
  EXPECT_EQ(outbox.path(), path_);
}

TEST_F(OutboxTest, AddIncreasesPendingAndAdvancesSequence) {
  Outbox outbox(path_, "drone_0", bounds());
  for (std::uint64_t s = 0; s < 3; ++s) outbox.add(distinctive_keyframe("drone_0", s), kStart);
  EXPECT_EQ(outbox.pending(), 3u);
  EXPECT_EQ(outbox.next_sequence(), 3u);
}

TEST_F(OutboxTest, AcknowledgeRemovesOnceAndThenReturnsFalse) {
  Outbox outbox(path_, "drone_0", bounds());
  for (std::uint64_t s = 0; s < 3; ++s) outbox.add(distinctive_keyframe("drone_0", s), kStart);
  EXPECT_TRUE(outbox.acknowledge(1));
  EXPECT_EQ(outbox.pending(), 2u);
  EXPECT_FALSE(outbox.acknowledge(1));
  EXPECT_EQ(outbox.pending(), 2u);
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart, 10)), (std::vector<std::uint64_t>{0, 2}));
}

// After a conflict the keyframe takes the next number, durably, and is due at once.
TEST_F(OutboxTest, RenumberGivesThePendingKeyframeTheNextSequence) {
  {
    Outbox outbox(path_, "drone_0", bounds());
    for (std::uint64_t s = 0; s < 3; ++s) add_sent(outbox, "drone_0", kStart);
    EXPECT_EQ(outbox.renumber(1), std::optional<std::uint64_t>(3));
    EXPECT_FALSE(outbox.renumber(1).has_value());  // no longer pending under 1
    EXPECT_EQ(outbox.next_sequence(), 4u);
    const auto due = outbox.due_for_resend(kStart, 10);  // the others were just sent
    ASSERT_EQ(sequences(due), (std::vector<std::uint64_t>{3}));
    EXPECT_EQ(due[0].image, distinctive_keyframe("drone_0", 1).image);
  }
  const Outbox reopened(path_, "drone_0", bounds());
  EXPECT_EQ(reopened.next_sequence(), 4u);
  EXPECT_EQ(reopened.pending(), 3u);
}

TEST_F(OutboxTest, AcknowledgeOfUnknownSequenceReturnsFalse) {
  Outbox outbox(path_, "drone_0", bounds());
  outbox.add(distinctive_keyframe("drone_0", 0), kStart);
  EXPECT_FALSE(outbox.acknowledge(42));
  EXPECT_EQ(outbox.pending(), 1u);
}

TEST_F(OutboxTest, AddWithWrongSequenceThrowsAndChangesNothing) {
  Outbox outbox(path_, "drone_0", bounds());
  outbox.add(distinctive_keyframe("drone_0", 0), kStart);
  EXPECT_ANY_THROW(outbox.add(distinctive_keyframe("drone_0", 5), kStart));
  EXPECT_ANY_THROW(outbox.add(distinctive_keyframe("drone_0", 0), kStart));
  EXPECT_EQ(outbox.next_sequence(), 1u);
  EXPECT_EQ(outbox.pending(), 1u);
  EXPECT_NO_THROW(outbox.add(distinctive_keyframe("drone_0", 1), kStart));
}

TEST_F(OutboxTest, SequenceAndPendingKeyframesSurviveReopening) {
  {
    Outbox outbox(path_, "drone_0", bounds());
    for (std::uint64_t s = 0; s < 3; ++s) outbox.add(distinctive_keyframe("drone_0", s), kStart);
  }
  Outbox reopened(path_, "drone_0", bounds());
  EXPECT_EQ(reopened.next_sequence(), 3u);
  EXPECT_EQ(reopened.pending(), 3u);
  const auto due = reopened.due_for_resend(kStart, 10);
  ASSERT_EQ(due.size(), 3u);
  EXPECT_EQ(due[2].image, distinctive_keyframe("drone_0", 2).image);
  EXPECT_NO_THROW(reopened.add(distinctive_keyframe("drone_0", 3), kStart));
}

TEST_F(OutboxTest, SequenceContinuesAfterReopeningEvenWhenEverythingWasAcknowledged) {
  {
    Outbox outbox(path_, "drone_0", bounds());
    outbox.add(distinctive_keyframe("drone_0", 0), kStart);
    outbox.add(distinctive_keyframe("drone_0", 1), kStart);
    ASSERT_TRUE(outbox.acknowledge(0));
    ASSERT_TRUE(outbox.acknowledge(1));
  }
  const Outbox reopened(path_, "drone_0", bounds());
  EXPECT_EQ(reopened.next_sequence(), 2u);
  EXPECT_EQ(reopened.pending(), 0u);
}

TEST_F(OutboxTest, OpeningAnotherRobotsOutboxThrowsStartupErrorNamingBoth) {
  { Outbox outbox(path_, "drone_a", bounds()); }
  try {
    Outbox other(path_, "drone_b", bounds());
    FAIL() << "expected StartupError";
  } catch (const StartupError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("drone_a"), std::string::npos) << message;
    EXPECT_NE(message.find("drone_b"), std::string::npos) << message;
    EXPECT_NE(message.find(path_), std::string::npos) << message;
  }
  EXPECT_NO_THROW(Outbox(path_, "drone_a", bounds()));
}

TEST_F(OutboxTest, UnopenablePathThrows) {
  EXPECT_ANY_THROW(Outbox(dir_.file("missing-dir/outbox.sqlite"), "drone_0", bounds()));
}

TEST_F(OutboxTest, DueForResendOnlyReturnsKeyframesSentAtLeastResendAfterAgo) {
  Outbox outbox(path_, "drone_0", bounds(2.0));
  add_sent(outbox, "drone_0", kStart + 1 * kSecond);  // sequence 0
  add_sent(outbox, "drone_0", kStart + 2 * kSecond);  // sequence 1

  EXPECT_TRUE(outbox.due_for_resend(kStart + 2 * kSecond, 10).empty());
  EXPECT_TRUE(outbox.due_for_resend(kStart + 3 * kSecond - 1, 10).empty());
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart + 3 * kSecond, 10)),
            (std::vector<std::uint64_t>{0}));
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart + 3 * kSecond + kSecond / 2, 10)),
            (std::vector<std::uint64_t>{0}));
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart + 4 * kSecond, 10)),
            (std::vector<std::uint64_t>{0, 1}));
}

TEST_F(OutboxTest, MarkSentPostponesTheNextResend) {
  Outbox outbox(path_, "drone_0", bounds(2.0));
  add_sent(outbox, "drone_0", kStart);
  ASSERT_EQ(outbox.due_for_resend(kStart + 2 * kSecond, 10).size(), 1u);
  outbox.mark_sent(0, kStart + 2 * kSecond);  // resent
  EXPECT_TRUE(outbox.due_for_resend(kStart + 3 * kSecond, 10).empty());
  EXPECT_EQ(outbox.due_for_resend(kStart + 4 * kSecond, 10).size(), 1u);
}

TEST_F(OutboxTest, KeyframeNeverSentIsDueImmediately) {
  Outbox outbox(path_, "drone_0", bounds(2.0));
  outbox.add(distinctive_keyframe("drone_0", 0), kStart);  // first publish failed: no mark_sent
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart, 10)), (std::vector<std::uint64_t>{0}));
}

TEST_F(OutboxTest, DueForResendIsOldestFirstAndHonoursMax) {
  Outbox outbox(path_, "drone_0", bounds(1.0));
  for (int i = 0; i < 5; ++i) add_sent(outbox, "drone_0", kStart);
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart + 10 * kSecond, 2)),
            (std::vector<std::uint64_t>{0, 1}));
  EXPECT_TRUE(outbox.due_for_resend(kStart + 10 * kSecond, 0).empty());
}

TEST_F(OutboxTest, AcknowledgedKeyframeIsNeverResent) {
  Outbox outbox(path_, "drone_0", bounds(1.0));
  add_sent(outbox, "drone_0", kStart);
  add_sent(outbox, "drone_0", kStart);
  ASSERT_TRUE(outbox.acknowledge(0));
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart + 5 * kSecond, 10)),
            (std::vector<std::uint64_t>{1}));
}

TEST_F(OutboxTest, ResentKeyframeHasIdenticalImageAndMetadataIncludingPose) {
  Outbox outbox(path_, "drone_7", bounds(1.0));
  const Keyframe original = distinctive_keyframe("drone_7", 0);
  outbox.add(original, kStart);
  outbox.mark_sent(0, kStart);

  const auto due = outbox.due_for_resend(kStart + 5 * kSecond, 10);
  ASSERT_EQ(due.size(), 1u);
  const Keyframe& k = due[0];
  EXPECT_EQ(k.robot_id, original.robot_id);
  EXPECT_EQ(k.sequence_number, original.sequence_number);
  EXPECT_EQ(k.frame_index, original.frame_index);
  EXPECT_EQ(k.capture_time_ns, original.capture_time_ns);
  EXPECT_EQ(k.vslam_keyframe_index, original.vslam_keyframe_index);
  EXPECT_EQ(k.window_first_frame, original.window_first_frame);
  EXPECT_EQ(k.window_last_frame, original.window_last_frame);
  EXPECT_EQ(k.quality_score, original.quality_score);
  EXPECT_EQ(k.sharpness_score, original.sharpness_score);
  EXPECT_EQ(k.semantic_score, original.semantic_score);
  EXPECT_EQ(k.encoding, original.encoding);
  EXPECT_EQ(k.width, original.width);
  EXPECT_EQ(k.height, original.height);
  EXPECT_EQ(k.image, original.image);
  ASSERT_TRUE(k.camera_pose.has_value());
  EXPECT_EQ(k.camera_pose->tx, original.camera_pose->tx);
  EXPECT_EQ(k.camera_pose->ty, original.camera_pose->ty);
  EXPECT_EQ(k.camera_pose->tz, original.camera_pose->tz);
  EXPECT_EQ(k.camera_pose->qx, original.camera_pose->qx);
  EXPECT_EQ(k.camera_pose->qy, original.camera_pose->qy);
  EXPECT_EQ(k.camera_pose->qz, original.camera_pose->qz);
  EXPECT_EQ(k.camera_pose->qw, original.camera_pose->qw);
}

TEST_F(OutboxTest, KeyframeWithoutPoseComesBackWithoutPose) {
  Outbox outbox(path_, "drone_0", bounds());
  Keyframe k = distinctive_keyframe("drone_0", 0);
  k.camera_pose.reset();
  outbox.add(k, kStart);
  const auto due = outbox.due_for_resend(kStart, 10);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_FALSE(due[0].camera_pose.has_value());
}

TEST_F(OutboxTest, EvictDropsOldestBeyondMaxPending) {
  Outbox outbox(path_, "drone_0", bounds(2.0, 3));
  for (int i = 0; i < 5; ++i) add_sent(outbox, "drone_0", kStart + i * kSecond);
  EXPECT_EQ(outbox.evict(kStart + 5 * kSecond), (std::vector<std::uint64_t>{0, 1}));
  EXPECT_EQ(outbox.pending(), 3u);
  EXPECT_EQ(sequences(outbox.due_for_resend(kStart + 100 * kSecond, 10)),
            (std::vector<std::uint64_t>{2, 3, 4}));
  EXPECT_TRUE(outbox.evict(kStart + 5 * kSecond).empty());
}

TEST_F(OutboxTest, EvictDropsKeyframesOlderThanMaxAge) {
  Outbox outbox(path_, "drone_0", bounds(2.0, 1000, 10.0));
  add_sent(outbox, "drone_0", kStart);                // 0: 12 s old at evict time
  add_sent(outbox, "drone_0", kStart + 2 * kSecond);  // 1: exactly 10 s old: kept
  add_sent(outbox, "drone_0", kStart + 5 * kSecond);  // 2: 7 s old
  EXPECT_EQ(outbox.evict(kStart + 12 * kSecond), (std::vector<std::uint64_t>{0}));
  EXPECT_EQ(outbox.pending(), 2u);
  EXPECT_EQ(outbox.evict(kStart + 16 * kSecond), (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(outbox.pending(), 0u);
}

TEST_F(OutboxTest, EvictionAgeCountsFromAddNotFromLastSend) {
  Outbox outbox(path_, "drone_0", bounds(2.0, 1000, 10.0));
  outbox.add(distinctive_keyframe("drone_0", 0), kStart);
  outbox.mark_sent(0, kStart + 9 * kSecond);
  EXPECT_EQ(outbox.evict(kStart + 11 * kSecond), (std::vector<std::uint64_t>{0}));
}

// The outbox's clock (boot time) starts again from 0 at a reboot: what was stored before is in its
// future. It is sent again at once and aged from the first eviction after the reboot, as keyframes
// are after an outage, never kept forever nor given up on at once.
TEST_F(OutboxTest, TimesFromBeforeARebootCountFromNow) {
  const std::int64_t before_reboot = kStart + 1000 * kSecond;
  {
    Outbox outbox(path_, "drone_0", bounds(2.0, 1000, 10.0));
    add_sent(outbox, "drone_0", before_reboot);
  }
  Outbox outbox(path_, "drone_0", bounds(2.0, 1000, 10.0));
  const std::int64_t after_reboot = kStart;
  EXPECT_EQ(sequences(outbox.due_for_resend(after_reboot, 10)), (std::vector<std::uint64_t>{0}));
  EXPECT_TRUE(outbox.evict(after_reboot).empty());
  EXPECT_TRUE(outbox.evict(after_reboot + 9 * kSecond).empty());
  EXPECT_EQ(outbox.evict(after_reboot + 11 * kSecond), (std::vector<std::uint64_t>{0}));
}

TEST_F(OutboxTest, EvictWithinBoundsKeepsEverything) {
  Outbox outbox(path_, "drone_0", bounds(2.0, 10, 100.0));
  for (int i = 0; i < 4; ++i) add_sent(outbox, "drone_0", kStart);
  EXPECT_TRUE(outbox.evict(kStart + kSecond).empty());
  EXPECT_EQ(outbox.pending(), 4u);
}

TEST_F(OutboxTest, EvictedSequenceCannotBeAcknowledgedAgain) {
  Outbox outbox(path_, "drone_0", bounds(2.0, 1));
  add_sent(outbox, "drone_0", kStart);
  add_sent(outbox, "drone_0", kStart);
  ASSERT_EQ(outbox.evict(kStart), (std::vector<std::uint64_t>{0}));
  EXPECT_FALSE(outbox.acknowledge(0));
  EXPECT_TRUE(outbox.acknowledge(1));
}

// What matters first: higher value before lower, age among equals, held keyframes only when
// asked for and after every other; the backlog counts only what is not held.
TEST_F(OutboxTest, SendsByValueThenAgeAndHeldOnlyWhenAskedFor) {
  {
    Outbox outbox(path_, "drone_0", bounds());
    const double values[] = {0.2, 0.9, 0.5, 0.9, 0.99};
    for (std::uint64_t s = 0; s < 5; ++s)
      outbox.add(distinctive_keyframe("drone_0", s), kStart, values[s], /*held=*/s == 4);
    EXPECT_EQ(sequences(outbox.due_for_resend(kStart, 10)),
              (std::vector<std::uint64_t>{1, 3, 2, 0}));
    EXPECT_EQ(sequences(outbox.due_for_resend(kStart, 10, true)),
              (std::vector<std::uint64_t>{1, 3, 2, 0, 4}));
    EXPECT_EQ(sequences(outbox.due_for_resend(kStart, 2)), (std::vector<std::uint64_t>{1, 3}));
    EXPECT_EQ(outbox.held(), 1u);
    const auto image_bytes = distinctive_keyframe("drone_0", 0).image.size();
    EXPECT_EQ(outbox.pending_bytes(), 4 * image_bytes);
  }
  const Outbox reopened(path_, "drone_0", bounds());  // the order is on disk
  EXPECT_EQ(reopened.held(), 1u);
}

TEST_F(OutboxTest, CountBoundGivesUpHeldKeyframesFirst) {
  Outbox outbox(path_, "drone_0", bounds(2.0, 3));
  for (std::uint64_t s = 0; s < 5; ++s)
    outbox.add(distinctive_keyframe("drone_0", s), kStart, 0.5, /*held=*/s == 2 || s == 4);
  EXPECT_EQ(outbox.evict(kStart), (std::vector<std::uint64_t>{2, 4}));
  EXPECT_EQ(outbox.held(), 0u);
  EXPECT_EQ(outbox.pending(), 3u);
}

}  // namespace
}  // namespace keyfleet::agent
