// KeyframeAgent driven in process: a scripted selector decides what is published, a real
// outbox and JPEG codec hold and encode it, a fake link refuses writes and delivers acks.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "fake_links.hpp"
#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/agent_runner.hpp"
#include "keyfleet/agent/keyframe_agent.hpp"
#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/agent/stage_clock.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "test_support.hpp"

namespace keyfleet::agent {
namespace {

using keyfleet::test::FakeAgentLink;

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kStart = 1'700'000'000 * kSecond;
constexpr int kJpegQuality = 85;

// Which frames the selector publishes (in the step that pushes them), which it reports as
// V-SLAM keyframes, and which it holds back until finish().
struct Script {
  std::set<std::uint64_t> select;
  std::set<std::uint64_t> vslam;
  std::set<std::uint64_t> at_finish;
};

Selection selection_of(const Frame& frame) {
  Selection s;
  s.frame = frame;
  s.vslam_keyframe_index = 1000 + frame.index;
  s.window_first_frame = frame.index;
  s.window_last_frame = frame.index + 4;
  s.quality_score = 0.5 + static_cast<double>(frame.index);
  s.sharpness_score = 321.25;
  s.semantic_score = 0.125;
  return s;
}

class ScriptedSelector final : public KeyframeSelector {
 public:
  explicit ScriptedSelector(Script script) : script_(std::move(script)) {}

  SelectorStep push(const Frame& frame) override {
    SelectorStep step;
    step.vslam_keyframe = script_.vslam.count(frame.index) > 0;
    if (script_.select.count(frame.index) > 0) step.selected.push_back(selection_of(frame));
    if (script_.at_finish.count(frame.index) > 0) held_.push_back(selection_of(frame));
    return step;
  }

  std::vector<Selection> finish() override { return std::move(held_); }

 private:
  Script script_;
  std::vector<Selection> held_;
};

// Noise of a width that depends on the index, so that frames differ in encoded size.
Frame make_frame(std::uint64_t index) {
  Frame frame;
  frame.index = index;
  frame.capture_time_ns = kStart + static_cast<std::int64_t>(index) * (kSecond / 30);
  frame.image = keyfleet::test::make_noise_image(16 + 8 * static_cast<int>(index % 5), 16,
                                                 static_cast<unsigned>(index) + 1);
  frame.pose = Pose{static_cast<double>(index), 2.0, -3.0, 0.0, 0.0, 0.0, 1.0};
  return frame;
}

// What FakeAgentLink reports for the keyframe made from this frame.
std::uint64_t sample_bytes(std::uint64_t index) {
  return JpegCodec(kJpegQuality).encode(make_frame(index).image).size() +
         FakeAgentLink::kKeyframeOverhead;
}

std::vector<std::uint64_t> sequences(const std::vector<Keyframe>& keyframes) {
  std::vector<std::uint64_t> out;
  for (const auto& k : keyframes) out.push_back(k.sequence_number);
  return out;
}

std::uint64_t reported_bytes(const FakeAgentLink& link, std::size_t first, std::size_t last) {
  std::uint64_t bytes = 0;
  for (std::size_t i = first; i < last; ++i) bytes += link.serialized_size(link.keyframes[i]);
  return bytes;
}

class KeyframeAgentTest : public ::testing::Test {
 protected:
  KeyframeAgentTest() {
    config_.robot_id = "drone_0";
    config_.codec.jpeg_quality = kJpegQuality;
    config_.ledger.baseline_sample_every = 1;
    config_.outbox.resend_after_s = 2.0;
    config_.outbox.resend_batch = 20;
    config_.outbox.max_pending = 1000;
    config_.outbox.max_age_s = 3600.0;
  }

  // Builds the agent from config_ (set it first) around a fresh outbox.
  void start(Script script) {
    outbox_ =
        std::make_unique<Outbox>(dir_.file("outbox.sqlite"), config_.robot_id, config_.outbox);
    agent_ = std::make_unique<KeyframeAgent>(
        config_, std::make_unique<ScriptedSelector>(std::move(script)),
        std::make_unique<JpegCodec>(config_.codec.jpeg_quality), *outbox_, link_, clock_,
        null_logger());
  }

  void process_frames(std::uint64_t count, std::int64_t now_ns) {
    for (std::uint64_t i = 0; i < count; ++i) agent_->process(make_frame(i), now_ns);
  }

  void service(std::int64_t now_ns) { agent_->service(now_ns, std::chrono::milliseconds(0)); }

  AgentStats stats() const { return agent_->stats(false, kStart); }

  std::uint64_t stage_calls(const std::string& stage) const {
    for (const auto& time : clock_.snapshot())
      if (time.stage == stage) return time.calls;
    return 0;
  }

  // Sequence numbers in the outbox, whatever their resend timers say, in increasing order (the
  // outbox's sending order is by value, tested with the outbox).
  std::vector<std::uint64_t> in_outbox() {
    auto in = sequences(outbox_->due_for_resend(kStart + 1'000'000 * kSecond, 1000, true));
    std::sort(in.begin(), in.end());
    return in;
  }

  static std::vector<std::uint64_t> sorted(std::vector<std::uint64_t> v) {
    std::sort(v.begin(), v.end());
    return v;
  }

  keyfleet::test::TempDir dir_;
  AgentConfig config_;
  FakeAgentLink link_;
  StageClock clock_;
  std::unique_ptr<Outbox> outbox_;
  std::unique_ptr<KeyframeAgent> agent_;
};

// --- first transmission ---

TEST_F(KeyframeAgentTest, SelectedFrameIsStoredInTheOutboxAndPublishedOnce) {
  start({{2}, {}, {}});
  process_frames(4, kStart);

  ASSERT_EQ(link_.keyframes.size(), 1u);
  EXPECT_EQ(link_.keyframe_attempts, 1u);
  const Keyframe& k = link_.keyframes[0];
  const Frame frame = make_frame(2);
  EXPECT_EQ(k.robot_id, "drone_0");
  EXPECT_EQ(k.sequence_number, 0u);
  EXPECT_EQ(k.frame_index, 2u);
  EXPECT_EQ(k.capture_time_ns, frame.capture_time_ns);
  EXPECT_EQ(k.encoding, "jpeg");
  EXPECT_EQ(k.width, static_cast<std::uint32_t>(frame.image.cols));
  EXPECT_EQ(k.height, static_cast<std::uint32_t>(frame.image.rows));
  EXPECT_EQ(k.image, JpegCodec(kJpegQuality).encode(frame.image));
  EXPECT_EQ(k.vslam_keyframe_index, 1002u);
  EXPECT_EQ(k.window_first_frame, 2u);
  EXPECT_EQ(k.window_last_frame, 6u);
  EXPECT_EQ(k.quality_score, 2.5);
  EXPECT_EQ(k.sharpness_score, 321.25);
  EXPECT_EQ(k.semantic_score, 0.125);
  ASSERT_TRUE(k.camera_pose.has_value());
  EXPECT_EQ(k.camera_pose->tx, 2.0);

  EXPECT_EQ(agent_->pending(), 1u);
  const auto stored = outbox_->due_for_resend(kStart + 100 * kSecond, 10);
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].sequence_number, 0u);
  EXPECT_EQ(stored[0].image, k.image);
}

// selector.decode_reduce: the selection saw a half-size decode; the keyframe sent and the
// baseline measured are the whole frame, decoded again from the source's file.
TEST_F(KeyframeAgentTest, AReducedFrameIsSentAndMeasuredWhole) {
  start({{1}, {1}, {}});
  const cv::Mat whole = keyfleet::test::make_noise_image(64, 48, 9);
  std::vector<std::uint8_t> file;
  ASSERT_TRUE(cv::imencode(".jpg", whole, file, {cv::IMWRITE_JPEG_QUALITY, 95}));
  const cv::Mat decoded = cv::imdecode(file, cv::IMREAD_COLOR);
  for (std::uint64_t i = 0; i < 2; ++i) {
    Frame frame = make_frame(i);
    frame.image = cv::imdecode(file, cv::IMREAD_REDUCED_COLOR_2);
    frame.full_size = whole.size();
    frame.encoded = std::make_shared<const std::vector<std::uint8_t>>(file);
    agent_->process(frame, kStart);
  }
  ASSERT_EQ(link_.keyframes.size(), 1u);
  const Keyframe& k = link_.keyframes[0];
  EXPECT_EQ(k.width, 64u);
  EXPECT_EQ(k.height, 48u);
  EXPECT_EQ(k.image, JpegCodec(kJpegQuality).encode(decoded));
  // Baselines of both frames: a whole frame's bytes each.
  const std::uint64_t whole_bytes = k.image.size() + FakeAgentLink::kKeyframeOverhead;
  EXPECT_EQ(stats().stream_all_bytes, 2 * whole_bytes);
  EXPECT_EQ(stats().vslam_keyframe_bytes, whole_bytes);
}

TEST_F(KeyframeAgentTest, SequenceNumbersCountUp) {
  start({{0, 1, 3}, {}, {}});
  process_frames(4, kStart);
  EXPECT_EQ(sequences(link_.keyframes), (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(outbox_->next_sequence(), 3u);
  EXPECT_EQ(agent_->pending(), 3u);
}

TEST_F(KeyframeAgentTest, SentBytesInStatsAreWhatTheLinkReported) {
  start({{0, 2, 3}, {}, {}});
  process_frames(4, kStart);
  ASSERT_EQ(link_.keyframes.size(), 3u);

  const AgentStats s = stats();
  EXPECT_EQ(s.keyframes_sent, 3u);
  EXPECT_EQ(s.bytes_sent, reported_bytes(link_, 0, 3));
  EXPECT_EQ(s.bytes_sent, sample_bytes(0) + sample_bytes(2) + sample_bytes(3));
  EXPECT_EQ(s.keyframes_resent, 0u);
  EXPECT_EQ(s.bytes_resent, 0u);
  EXPECT_EQ(s.keyframes_pending, 3u);
}

// --- resends ---

TEST_F(KeyframeAgentTest, NothingIsResentBeforeTheTimeout) {
  start({{0}, {}, {}});
  process_frames(1, kStart);
  service(kStart);
  service(kStart + 2 * kSecond - 1);
  EXPECT_EQ(link_.keyframe_attempts, 1u);
  EXPECT_EQ(stats().keyframes_resent, 0u);
}

TEST_F(KeyframeAgentTest, UnacknowledgedKeyframeIsResentAfterTheTimeoutAsAResend) {
  start({{0}, {}, {}});
  process_frames(1, kStart);
  service(kStart + 2 * kSecond);

  ASSERT_EQ(link_.keyframes.size(), 2u);
  EXPECT_EQ(link_.keyframes[1].sequence_number, 0u);
  EXPECT_EQ(link_.keyframes[1].robot_id, "drone_0");
  EXPECT_EQ(link_.keyframes[1].image, link_.keyframes[0].image);
  const AgentStats s = stats();
  EXPECT_EQ(s.keyframes_sent, 1u);
  EXPECT_EQ(s.bytes_sent, reported_bytes(link_, 0, 1));
  EXPECT_EQ(s.keyframes_resent, 1u);
  EXPECT_EQ(s.bytes_resent, reported_bytes(link_, 1, 2));
  EXPECT_EQ(agent_->pending(), 1u);  // still unacknowledged
}

TEST_F(KeyframeAgentTest, ResendRestartsTheTimeout) {
  start({{0}, {}, {}});
  process_frames(1, kStart);
  service(kStart + 2 * kSecond);
  ASSERT_EQ(link_.keyframes.size(), 2u);
  service(kStart + 4 * kSecond - 1);
  EXPECT_EQ(link_.keyframes.size(), 2u);
  service(kStart + 4 * kSecond);
  EXPECT_EQ(link_.keyframes.size(), 3u);
  EXPECT_EQ(stats().keyframes_resent, 2u);
}

TEST_F(KeyframeAgentTest, NoResendWhileNoStationIsMatched) {
  start({{0}, {}, {}});
  process_frames(1, kStart);
  link_.matched = 0;
  service(kStart + 10 * kSecond);
  service(kStart + 20 * kSecond);
  EXPECT_EQ(link_.keyframe_attempts, 1u);
  EXPECT_EQ(agent_->pending(), 1u);

  link_.matched = 1;
  service(kStart + 21 * kSecond);
  ASSERT_EQ(link_.keyframes.size(), 2u);
  EXPECT_EQ(link_.keyframes[1].sequence_number, 0u);
  EXPECT_EQ(stats().keyframes_resent, 1u);
}

TEST_F(KeyframeAgentTest, ResendBatchBoundsRetransmissionsPerPass) {
  config_.outbox.resend_batch = 2;
  start({{0, 1, 2, 3, 4}, {}, {}});
  process_frames(5, kStart);
  ASSERT_EQ(link_.keyframes.size(), 5u);

  service(kStart + 2 * kSecond);
  EXPECT_EQ(link_.keyframes.size(), 7u);
  service(kStart + 2 * kSecond);
  EXPECT_EQ(link_.keyframes.size(), 9u);
  service(kStart + 2 * kSecond);
  EXPECT_EQ(link_.keyframes.size(), 10u);
  const std::vector<Keyframe> resent(link_.keyframes.begin() + 5, link_.keyframes.end());
  EXPECT_EQ(sorted(sequences(resent)), (std::vector<std::uint64_t>{0, 1, 2, 3, 4}));  // each once
  EXPECT_EQ(stats().keyframes_resent, 5u);
}

// --- refused writes ---

TEST_F(KeyframeAgentTest, RefusedFirstWriteStaysInTheOutboxAndIsNotCountedAsSent) {
  link_.refuse_next = 1;
  start({{0}, {}, {}});
  process_frames(1, kStart);

  EXPECT_EQ(link_.keyframe_attempts, 1u);
  EXPECT_TRUE(link_.keyframes.empty());
  EXPECT_EQ(agent_->pending(), 1u);
  const AgentStats s = stats();
  EXPECT_EQ(s.keyframes_sent, 0u);
  EXPECT_EQ(s.bytes_sent, 0u);
  EXPECT_EQ(s.keyframes_resent, 0u);
}

TEST_F(KeyframeAgentTest, RefusedFirstWriteIsSentOnTheNextPassAndCountedAsSent) {
  link_.refuse_next = 1;
  start({{0}, {}, {}});
  process_frames(1, kStart);
  service(kStart);  // never sent, so due at once

  ASSERT_EQ(link_.keyframes.size(), 1u);
  EXPECT_EQ(link_.keyframes[0].sequence_number, 0u);
  AgentStats s = stats();
  EXPECT_EQ(s.keyframes_sent, 1u);
  EXPECT_EQ(s.bytes_sent, reported_bytes(link_, 0, 1));
  EXPECT_EQ(s.keyframes_resent, 0u);
  EXPECT_EQ(s.bytes_resent, 0u);

  // From then on it is an ordinary sent keyframe: the next copy is a resend.
  service(kStart + kSecond);
  EXPECT_EQ(link_.keyframes.size(), 1u);
  service(kStart + 2 * kSecond);
  ASSERT_EQ(link_.keyframes.size(), 2u);
  s = stats();
  EXPECT_EQ(s.keyframes_sent, 1u);
  EXPECT_EQ(s.keyframes_resent, 1u);
}

TEST_F(KeyframeAgentTest, RefusedFirstWriteWaitsForAStation) {
  link_.refuse_next = 1;
  link_.matched = 0;
  start({{0}, {}, {}});
  process_frames(1, kStart);
  service(kStart + kSecond);
  EXPECT_EQ(link_.keyframe_attempts, 1u);

  link_.matched = 1;
  service(kStart + 2 * kSecond);
  ASSERT_EQ(link_.keyframes.size(), 1u);
  EXPECT_EQ(stats().keyframes_sent, 1u);
}

TEST_F(KeyframeAgentTest, RefusalDuringAResendPassStopsThatPass) {
  start({{0, 1, 2}, {}, {}});
  process_frames(3, kStart);
  ASSERT_EQ(link_.keyframes.size(), 3u);

  link_.refuse_next = 1;
  service(kStart + 2 * kSecond);
  EXPECT_EQ(link_.keyframe_attempts, 4u);  // the first refusal ends the pass
  EXPECT_EQ(link_.keyframes.size(), 3u);
  EXPECT_EQ(stats().keyframes_resent, 0u);
  EXPECT_EQ(agent_->pending(), 3u);

  // Nothing was marked sent, so all three are still due.
  service(kStart + 2 * kSecond);
  const std::vector<Keyframe> resent(link_.keyframes.begin() + 3, link_.keyframes.end());
  EXPECT_EQ(sorted(sequences(resent)), (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(stats().keyframes_resent, 3u);
}

TEST_F(KeyframeAgentTest, RefusalMidPassLeavesTheRestForTheNextPass) {
  start({{0, 1, 2}, {}, {}});
  process_frames(3, kStart);
  ASSERT_EQ(link_.keyframes.size(), 3u);

  const auto order = sequences(outbox_->due_for_resend(kStart + 2 * kSecond, 3));
  ASSERT_EQ(order.size(), 3u);
  link_.accept_before_refusing = 1;
  link_.refuse_next = 1;
  service(kStart + 2 * kSecond);
  EXPECT_EQ(link_.keyframe_attempts, 5u);  // the first due resent, the second refused
  EXPECT_EQ(sequences(link_.keyframes).back(), order[0]);
  EXPECT_EQ(stats().keyframes_resent, 1u);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{0, 1, 2}));

  service(kStart + 2 * kSecond);  // the first was just resent; the other two are still due
  const std::vector<Keyframe> resent(link_.keyframes.begin() + 3, link_.keyframes.end());
  EXPECT_EQ(sorted(sequences(resent)), (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(stats().keyframes_resent, 3u);
}

// --- outbox bounds ---

TEST_F(KeyframeAgentTest, EvictionByCountDropsTheOldestAndCountsThem) {
  config_.outbox.max_pending = 2;
  start({{0, 1, 2, 3}, {}, {}});
  process_frames(4, kStart);
  EXPECT_EQ(agent_->pending(), 4u);  // bounds apply in service()

  service(kStart);
  EXPECT_EQ(agent_->pending(), 2u);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{2, 3}));
  const AgentStats s = stats();
  EXPECT_EQ(s.keyframes_dropped, 2u);
  EXPECT_EQ(s.keyframes_pending, 2u);
  EXPECT_EQ(s.keyframes_sent, 4u);

  service(kStart + 2 * kSecond);  // the dropped ones are not resent
  const std::vector<Keyframe> resent(link_.keyframes.begin() + 4, link_.keyframes.end());
  EXPECT_EQ(sequences(resent), (std::vector<std::uint64_t>{2, 3}));
  EXPECT_EQ(stats().keyframes_dropped, 2u);
}

TEST_F(KeyframeAgentTest, EvictionByAgeDropsExpiredKeyframesAndCountsThem) {
  config_.outbox.max_age_s = 10.0;  // a station is matched all along but never acknowledges
  start({{0, 1}, {}, {}});
  agent_->process(make_frame(0), kStart);
  agent_->process(make_frame(1), kStart + 5 * kSecond);

  service(kStart + 10 * kSecond);  // exactly max_age_s old: kept
  EXPECT_EQ(agent_->pending(), 2u);
  EXPECT_EQ(stats().keyframes_dropped, 0u);

  service(kStart + 10 * kSecond + 1);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{1}));
  EXPECT_EQ(stats().keyframes_dropped, 1u);

  service(kStart + 15 * kSecond + 1);
  EXPECT_EQ(agent_->pending(), 0u);
  EXPECT_EQ(stats().keyframes_dropped, 2u);
}

TEST_F(KeyframeAgentTest, AnOutageLongerThanMaxAgeLosesNothingTheCountBoundKeeps) {
  config_.outbox.max_age_s = 10.0;
  link_.matched = 0;  // no station: an outage of an hour
  start({{0, 1}, {}, {}});
  agent_->process(make_frame(0), kStart);
  agent_->process(make_frame(1), kStart + 5 * kSecond);
  service(kStart + 3600 * kSecond);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{0, 1}));
  EXPECT_EQ(stats().keyframes_dropped, 0u);

  // The station comes back: the keyframes get max_age_s from then to be acknowledged.
  link_.matched = 1;
  service(kStart + 3601 * kSecond);
  service(kStart + 3611 * kSecond);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{0, 1}));
  service(kStart + 3611 * kSecond + 1);  // matched more than max_age_s, still unacknowledged
  EXPECT_TRUE(in_outbox().empty());
  EXPECT_EQ(stats().keyframes_dropped, 2u);
}

TEST_F(KeyframeAgentTest, AKeyframeTheBoundsGiveUpOnIsNotResentFirst) {
  config_.outbox.max_age_s = 10.0;
  start({{0}, {}, {}});
  process_frames(1, kStart);
  ASSERT_EQ(link_.keyframes.size(), 1u);

  service(kStart + 10 * kSecond + 1);  // due for a resend and past max_age_s at once
  EXPECT_EQ(link_.keyframes.size(), 1u);
  const AgentStats s = stats();
  EXPECT_EQ(s.keyframes_resent, 0u);
  EXPECT_EQ(s.keyframes_dropped, 1u);
}

TEST_F(KeyframeAgentTest, EvictedNeverSentKeyframeIsDroppedNotSent) {
  config_.outbox.max_pending = 1;
  link_.refuse_all = true;
  start({{0, 1}, {}, {}});
  process_frames(2, kStart);
  service(kStart);
  link_.refuse_all = false;
  service(kStart);

  EXPECT_EQ(sequences(link_.keyframes), (std::vector<std::uint64_t>{1}));
  const AgentStats s = stats();
  EXPECT_EQ(s.keyframes_dropped, 1u);
  EXPECT_EQ(s.keyframes_sent, 1u);
  EXPECT_EQ(s.keyframes_resent, 0u);
}

// --- acknowledgements ---

TEST_F(KeyframeAgentTest, StoredAckRemovesTheKeyframeFromTheOutbox) {
  start({{0, 1}, {}, {}});
  process_frames(2, kStart);
  link_.queue_ack("drone_0", 0, AckStatus::kStored);
  service(kStart);

  EXPECT_EQ(agent_->pending(), 1u);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{1}));
  EXPECT_EQ(agent_->rejected(), 0u);

  service(kStart + 2 * kSecond);  // only the unacknowledged one comes back
  ASSERT_EQ(link_.keyframes.size(), 3u);
  EXPECT_EQ(link_.keyframes[2].sequence_number, 1u);
}

TEST_F(KeyframeAgentTest, DuplicateAckAlsoRemovesTheKeyframe) {
  start({{0}, {}, {}});
  process_frames(1, kStart);
  link_.queue_ack("drone_0", 0, AckStatus::kDuplicate);
  service(kStart);
  EXPECT_EQ(agent_->pending(), 0u);
  EXPECT_EQ(agent_->rejected(), 0u);
}

// The station holds sequence 0 with another image (this robot lost its numbering): the
// keyframe is not deleted but sent again at once under the next number.
TEST_F(KeyframeAgentTest, ConflictAckSendsTheKeyframeAgainUnderANewNumber) {
  start({{0, 1}, {}, {}});
  process_frames(2, kStart);
  link_.queue_ack("drone_0", 0, AckStatus::kConflict, "already stored with another image");
  service(kStart);
  EXPECT_EQ(agent_->pending(), 2u);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{1, 2}));
  ASSERT_EQ(link_.keyframes.size(), 3u);
  EXPECT_EQ(link_.keyframes[2].sequence_number, 2u);
  EXPECT_EQ(link_.keyframes[2].image, link_.keyframes[0].image);
  EXPECT_EQ(agent_->rejected(), 0u);
  EXPECT_EQ(outbox_->next_sequence(), 3u);  // new keyframes number after it
}

TEST_F(KeyframeAgentTest, RejectedAckCountsOnlyWhenTheKeyframeWasPending) {
  start({{0, 1}, {}, {}});
  process_frames(2, kStart);
  link_.queue_ack("drone_0", 0, AckStatus::kRejected, "bad jpeg");
  service(kStart);
  EXPECT_EQ(agent_->rejected(), 1u);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{1}));  // not sent again

  link_.queue_ack("drone_0", 0, AckStatus::kRejected, "bad jpeg");  // a repeat
  link_.queue_ack("drone_0", 7, AckStatus::kRejected, "bad jpeg");  // never published
  service(kStart);
  EXPECT_EQ(agent_->rejected(), 1u);
  EXPECT_EQ(agent_->pending(), 1u);
}

TEST_F(KeyframeAgentTest, AckForUnknownOrAcknowledgedSequenceChangesNothing) {
  start({{0, 1}, {}, {}});
  process_frames(2, kStart);
  link_.queue_ack("drone_0", 0, AckStatus::kStored);
  service(kStart);
  ASSERT_EQ(agent_->pending(), 1u);
  const AgentStats before = stats();

  link_.queue_ack("drone_0", 0, AckStatus::kStored);
  link_.queue_ack("drone_0", 42, AckStatus::kStored);
  link_.queue_ack("drone_0", 42, AckStatus::kDuplicate);
  ASSERT_NO_THROW(service(kStart));

  EXPECT_EQ(agent_->pending(), 1u);
  EXPECT_EQ(in_outbox(), (std::vector<std::uint64_t>{1}));
  EXPECT_EQ(agent_->rejected(), 0u);
  const AgentStats after = stats();
  EXPECT_EQ(after.keyframes_sent, before.keyframes_sent);
  EXPECT_EQ(after.keyframes_resent, before.keyframes_resent);
  EXPECT_EQ(after.keyframes_dropped, before.keyframes_dropped);
  EXPECT_EQ(link_.keyframes.size(), 2u);
}

TEST_F(KeyframeAgentTest, TakesOnlyAcksAddressedToItsRobot) {
  start({{0}, {}, {}});
  process_frames(1, kStart);
  link_.queue_ack("drone_9", 0, AckStatus::kStored);
  agent_->service(kStart, std::chrono::milliseconds(7));

  EXPECT_EQ(link_.ack_requests, (std::vector<std::string>{"drone_0"}));
  EXPECT_EQ(link_.last_ack_wait, std::chrono::milliseconds(7));
  EXPECT_EQ(link_.queued_acks(), 1u);  // still waiting for drone_9
  EXPECT_EQ(agent_->pending(), 1u);
}

// --- ledger and stats ---

TEST_F(KeyframeAgentTest, CountsEveryFrameSeenAndPublishesOnlySelections) {
  start({{3}, {}, {}});
  process_frames(7, kStart);
  EXPECT_EQ(stats().frames_seen, 7u);
  EXPECT_EQ(link_.keyframe_attempts, 1u);  // measuring the baselines publishes nothing
}

TEST_F(KeyframeAgentTest, StreamAllBaselineIsMeasuredOnEveryFrameWhenSamplingEach) {
  start({{}, {}, {}});
  process_frames(3, kStart);
  const AgentStats s = stats();
  EXPECT_EQ(s.stream_all_sampled_frames, 3u);
  EXPECT_FALSE(s.stream_all_estimated);
  EXPECT_EQ(s.stream_all_bytes, sample_bytes(0) + sample_bytes(1) + sample_bytes(2));
}

TEST_F(KeyframeAgentTest, StreamAllBaselineSamplesOneFrameInNAndExtrapolates) {
  config_.ledger.baseline_sample_every = 3;
  start({{}, {}, {}});
  process_frames(7, kStart);  // frames 0, 3 and 6 are measured

  const AgentStats s = stats();
  EXPECT_EQ(s.frames_seen, 7u);
  EXPECT_EQ(s.stream_all_sampled_frames, 3u);
  EXPECT_TRUE(s.stream_all_estimated);
  const double mean =
      static_cast<double>(sample_bytes(0) + sample_bytes(3) + sample_bytes(6)) / 3.0;
  EXPECT_EQ(s.stream_all_bytes, static_cast<std::uint64_t>(std::llround(mean * 7.0)));
  EXPECT_EQ(stage_calls("baseline"), 3u);  // the other frames are not encoded
}

TEST_F(KeyframeAgentTest, VslamBaselineMeasuresEveryVslamKeyframe) {
  config_.ledger.baseline_sample_every = 4;  // frames 1 and 2 are not stream-all samples
  start({{}, {1, 2}, {}});
  process_frames(4, kStart);

  const AgentStats s = stats();
  EXPECT_EQ(s.vslam_keyframes, 2u);
  EXPECT_FALSE(s.vslam_keyframe_estimated);
  EXPECT_EQ(s.vslam_keyframe_bytes, sample_bytes(1) + sample_bytes(2));
  EXPECT_EQ(s.stream_all_sampled_frames, 1u);  // a V-SLAM keyframe is not a stream sample
  EXPECT_EQ(s.stream_all_bytes, sample_bytes(0) * 4);
  EXPECT_EQ(stage_calls("baseline"), 3u);  // frames 0, 1 and 2; not frame 3
  EXPECT_TRUE(link_.keyframes.empty());
}

TEST_F(KeyframeAgentTest, FinishStreamPublishesWhatTheSelectorStillHolds) {
  start({{1}, {}, {3, 4}});
  process_frames(6, kStart);
  ASSERT_EQ(link_.keyframes.size(), 1u);

  agent_->finish_stream(kStart + kSecond);
  ASSERT_EQ(link_.keyframes.size(), 3u);
  EXPECT_EQ(link_.keyframes[1].frame_index, 3u);
  EXPECT_EQ(link_.keyframes[1].sequence_number, 1u);
  EXPECT_EQ(link_.keyframes[2].frame_index, 4u);
  EXPECT_EQ(link_.keyframes[2].sequence_number, 2u);
  EXPECT_EQ(agent_->pending(), 3u);
  EXPECT_EQ(stats().keyframes_sent, 3u);
}

TEST_F(KeyframeAgentTest, PublishStatsSendsTheLedgerWithFinishedSet) {
  start({{0, 2}, {1}, {}});
  process_frames(3, kStart);
  link_.queue_ack("drone_0", 0, AckStatus::kStored);
  service(kStart);

  agent_->publish_stats(true, kStart + 5 * kSecond);
  ASSERT_EQ(link_.stats.size(), 1u);
  const AgentStats& s = link_.stats[0];
  EXPECT_EQ(s.robot_id, "drone_0");
  EXPECT_TRUE(s.finished);
  EXPECT_EQ(s.report_time_ns, kStart + 5 * kSecond);
  EXPECT_EQ(s.frames_seen, 3u);
  EXPECT_EQ(s.vslam_keyframes, 1u);
  EXPECT_EQ(s.keyframes_sent, 2u);
  EXPECT_EQ(s.bytes_sent, reported_bytes(link_, 0, 2));
  EXPECT_EQ(s.keyframes_pending, 1u);
  std::set<std::string> stages;
  for (const auto& stage : s.stages) stages.insert(stage.stage);
  for (const char* stage : {"baseline", "encode", "publish", "service"})
    EXPECT_EQ(stages.count(stage), 1u) << stage;

  agent_->publish_stats(false, kStart + 6 * kSecond);
  ASSERT_EQ(link_.stats.size(), 2u);
  EXPECT_FALSE(link_.stats[1].finished);
}

TEST_F(KeyframeAgentTest, RefusedStatsWriteIsNotFatal) {
  start({{}, {}, {}});
  link_.refuse_next = 1;
  EXPECT_NO_THROW(agent_->publish_stats(true, kStart));
  EXPECT_TRUE(link_.stats.empty());
}

// `count` of make_frame's frames at `fps`.
class FixedSource final : public FrameSource {
 public:
  FixedSource(std::uint64_t count, double fps) : count_(count), fps_(fps) {}
  std::optional<Frame> next() override {
    if (next_ >= count_) return std::nullopt;
    return make_frame(next_++);
  }
  double fps() const override { return fps_; }
  std::string describe() const override { return "fixed frames"; }

 private:
  std::uint64_t count_, next_ = 0;
  double fps_;
};

// As the DDS link, a wait for acknowledgements blocks for as long as it is given when none
// comes (none does here); records every wait.
class WaitingAgentLink final : public FakeAgentLink {
 public:
  std::vector<KeyframeAck> take_acks(const std::string& robot_id,
                                     std::chrono::milliseconds wait) override {
    waits.push_back(wait);
    std::unique_lock<std::mutex> lock(mutex_);
    arrived_.wait_for(lock, wait, [] { return false; });
    return FakeAgentLink::take_acks(robot_id, wait);
  }
  std::vector<std::chrono::milliseconds> waits;

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
};

TEST(AgentRunner, WaitsForTheNextFrameWithoutSpinning) {
  // Between real-time frames the runner serves acknowledgements while it waits for the next
  // frame's time. A remainder of under a millisecond used to become a wait of none, on which
  // the loop spun until the frame was due: about 30 passes of the outbox's service a frame in
  // the fleet (0.3 ms of an agent's CPU a frame), where one or two waits do.
  keyfleet::test::TempDir dir;
  AgentConfig config;
  config.robot_id = "drone_0";
  config.source.realtime = true;
  Outbox outbox(dir.file("outbox.sqlite"), config.robot_id, config.outbox);
  WaitingAgentLink link;
  StageClock clock;
  KeyframeAgent agent(config, std::make_unique<ScriptedSelector>(Script{}),
                      std::make_unique<JpegCodec>(kJpegQuality), outbox, link, clock,
                      null_logger());
  constexpr std::uint64_t kFrames = 40;
  FixedSource source(kFrames, 100.0);  // 0.4 s of flight
  AgentRunner runner(config, source, agent, link, clock, null_logger());
  StopToken stop;
  EXPECT_EQ(runner.run(stop), AgentOutcome::kDelivered);
  EXPECT_EQ(runner.summary().frames, kFrames);
  const auto none = std::count(link.waits.begin(), link.waits.end(), std::chrono::milliseconds(0));
  // A wait of none only where a frame was done after the next one was due (late).
  EXPECT_LE(std::uint64_t(none), runner.summary().late_frames + 1) << link.waits.size() << " waits";
  EXPECT_LE(link.waits.size(), 3 * kFrames) << none << " of them of none";
}

}  // namespace
}  // namespace keyfleet::agent
