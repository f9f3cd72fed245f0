// The link estimator and the send controller on acknowledgement traces: a simulated link (a FIFO
// at a rate, with a delay) serves what the controller sends, and the traces step its rate down,
// up, and cut it off.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <deque>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "keyfleet/agent/level_encoding.hpp"
#include "keyfleet/agent/link_aware_sender.hpp"
#include "keyfleet/agent/link_estimator.hpp"
#include "keyfleet/agent/send_controller.hpp"
#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"

namespace keyfleet::agent {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kSecond = 1000 * kMs;

// A link that carries `rate(t)` bytes per second in order, with a fixed one-way delay for the
// acknowledgement; rate 0 is an outage (nothing moves).
struct SimLink {
  struct Item {
    std::uint64_t sequence;
    double left;  // bytes not yet carried
    std::int64_t selected_ns;
  };
  std::deque<Item> queue;
  std::vector<std::pair<std::int64_t, Item>> acks_due;  // (time, item)
  std::int64_t delay_ns = 50 * kMs;

  void send(std::uint64_t sequence, std::uint64_t bytes, std::int64_t now_ns) {
    queue.push_back({sequence, static_cast<double>(bytes), now_ns});
  }
  // Moves the link forward by dt at `rate`.
  void advance(std::int64_t now_ns, std::int64_t dt_ns, double rate) {
    double budget = rate * static_cast<double>(dt_ns) * 1e-9;
    while (!queue.empty() && budget > 0) {
      const double taken = std::min(budget, queue.front().left);
      queue.front().left -= taken;
      budget -= taken;
      if (queue.front().left <= 0) {
        acks_due.push_back({now_ns + dt_ns + delay_ns, queue.front()});
        queue.pop_front();
      }
    }
  }
  // The acknowledgements due by now, in the order they were carried.
  std::vector<std::pair<std::int64_t, Item>> take_acks(std::int64_t now_ns) {
    std::vector<std::pair<std::int64_t, Item>> due;
    for (auto it = acks_due.begin(); it != acks_due.end();) {
      if (it->first <= now_ns) {
        due.push_back(*it);
        it = acks_due.erase(it);
      } else {
        ++it;
      }
    }
    return due;
  }
};

struct Delivery {
  std::int64_t selected_ns;
  std::int64_t acked_ns;
  std::size_t level;
};

// One selection a second for `seconds`; keyframes at level i cost costs[i] bytes. Returns each
// delivered keyframe with its latency; `levels` gets the level at each selection.
struct Trace {
  std::vector<Delivery> deliveries;
  std::vector<std::size_t> levels;
  std::uint64_t thinned = 0;
  double latency_s(std::size_t i) const {
    return static_cast<double>(deliveries[i].acked_ns - deliveries[i].selected_ns) * 1e-9;
  }
  // The worst latency of keyframes selected in [from_s, to_s).
  double worst_latency(double from_s, double to_s) const {
    double worst = 0;
    for (std::size_t i = 0; i < deliveries.size(); ++i) {
      const double t = static_cast<double>(deliveries[i].selected_ns) * 1e-9;
      if (t >= from_s && t < to_s) worst = std::max(worst, latency_s(i));
    }
    return worst;
  }
};

template <class RateAt>
Trace fly(const LinkAdaptationConfig& config, RateAt rate_at, int seconds) {
  SendController controller(config, 85);
  LinkEstimator estimator(config.estimator_window_s);
  SimLink link;
  Trace trace;
  // 50 kB at the richest level, the rest in the JPEG model's proportions, measured exactly.
  const std::vector<double> relative = {1.0, 0.64, 0.47, 0.36, 0.36 * 0.5625, 0.36 * 0.25};
  for (std::size_t i = 0; i < controller.ladder().size(); ++i)
    controller.on_cost(i,
                       static_cast<std::uint64_t>(50'000 * relative[std::min(i, std::size_t(5))]));
  std::uint64_t sequence = 0;
  std::vector<std::size_t> level_of;
  const std::int64_t step = 10 * kMs;
  for (std::int64_t now = 0; now < seconds * kSecond; now += step) {
    const double rate = rate_at(static_cast<double>(now) * 1e-9);
    link.advance(now, step, rate);
    for (const auto& [at, item] : link.take_acks(now)) {
      estimator.on_acked(item.sequence, at);
      trace.deliveries.push_back({item.selected_ns, at, level_of[item.sequence]});
    }
    controller.update(now, estimator.estimate(now), estimator.bytes_in_flight());
    if (now % kSecond == 0) {
      controller.on_selection(now);
      const std::size_t level = controller.level_index();
      trace.levels.push_back(level);
      const auto bytes =
          static_cast<std::uint64_t>(50'000 * relative[std::min(level, std::size_t(5))]);
      level_of.push_back(level);
      if (controller.send_now()) {
        estimator.on_sent(sequence, bytes, now);
        link.send(sequence, bytes, now);
      } else {
        ++trace.thinned;
      }
      ++sequence;
    }
  }
  return trace;
}

LinkAdaptationConfig adaptive() {
  LinkAdaptationConfig c;
  c.enabled = true;
  return c;
}

TEST(LinkEstimator, SteadyBackloggedLinkGivesItsRate) {
  LinkEstimator estimator(10.0);
  SimLink link;
  const std::int64_t step = 10 * kMs;
  std::uint64_t sequence = 0;
  for (std::int64_t now = 0; now < 30 * kSecond; now += step) {
    link.advance(now, step, 20'000);
    for (const auto& [at, item] : link.take_acks(now)) estimator.on_acked(item.sequence, at);
    if (now % (500 * kMs) == 0) {  // 30 kB/s offered on a 20 kB/s link: always busy
      estimator.on_sent(sequence, 15'000, now);
      link.send(sequence++, 15'000, now);
    }
  }
  const LinkEstimate e = estimator.estimate(30 * kSecond);
  ASSERT_TRUE(e.known);
  EXPECT_NEAR(e.delivery_bytes_per_s, 20'000, 1'500);
  EXPECT_GT(estimator.bytes_in_flight(), 100'000u);  // the backlog is what was not acknowledged
}

TEST(LinkEstimator, IdleTimeIsNotCountedAndRoundTripsComeFromFirstSendsOnly) {
  LinkEstimator estimator(10.0, 0.1);
  // One 10 kB keyframe every 5 s, each acknowledged 0.5 s after it is sent: 20 kB/s busy.
  for (int i = 0; i < 6; ++i) {
    estimator.on_sent(i, 10'000, i * 5 * kSecond);
    estimator.on_acked(i, i * 5 * kSecond + 500 * kMs);
  }
  LinkEstimate e = estimator.estimate(40 * kSecond);
  EXPECT_NEAR(e.delivery_bytes_per_s, 20'000, 1);
  EXPECT_NEAR(e.rtt_s, 0.5, 1e-6);
  // A resent keyframe's acknowledgement gives no round trip (it may answer the first copy).
  estimator.on_sent(10, 10'000, 50 * kSecond);
  estimator.on_resent(10);
  estimator.on_acked(10, 58 * kSecond);
  e = estimator.estimate(60 * kSecond);
  EXPECT_NEAR(e.rtt_s, 0.5, 1e-6);
  EXPECT_NEAR(e.min_rtt_s, 0.5, 1e-6);
}

TEST(LinkEstimator, AStalledLinkLosesItsRateAndAPausedOneKeepsIt) {
  LinkEstimator estimator(10.0);
  for (int i = 0; i < 10; ++i) {
    estimator.on_sent(i, 10'000, i * kSecond);
    estimator.on_acked(i, i * kSecond + 500 * kMs);
  }
  const double before = estimator.estimate(10 * kSecond).delivery_bytes_per_s;
  EXPECT_NEAR(before, 20'000, 1);
  // Sent, never acknowledged, station still matched: the rate falls as the silence lasts.
  estimator.on_sent(100, 10'000, 10 * kSecond);
  EXPECT_LT(estimator.estimate(30 * kSecond).delivery_bytes_per_s, before / 2);
  EXPECT_LT(estimator.estimate(100 * kSecond).delivery_bytes_per_s, 1'000);
  // No station at all: the outage is not the link's delivery time.
  LinkEstimator paused(10.0);
  for (int i = 0; i < 10; ++i) {
    paused.on_sent(i, 10'000, i * kSecond);
    paused.on_acked(i, i * kSecond + 500 * kMs);
  }
  paused.on_sent(100, 10'000, 10 * kSecond);
  paused.pause(10 * kSecond + 100 * kMs);
  EXPECT_GT(paused.estimate(25 * kSecond).delivery_bytes_per_s, before * 0.9);
  paused.resume(25 * kSecond);
  paused.on_acked(100, 25 * kSecond + 600 * kMs);
  EXPECT_NEAR(paused.estimate(26 * kSecond).rtt_s, 0.5, 1e-6);  // no sample from the outage
  EXPECT_EQ(paused.bytes_in_flight(), 0u);
}

TEST(LinkEstimator, APriorStandsInUntilTheLinkIsMeasured) {
  LinkEstimator estimator(10.0);
  estimator.set_prior(20'000);
  LinkEstimate e = estimator.estimate(0);
  EXPECT_TRUE(e.known);
  EXPECT_TRUE(e.from_prior);
  EXPECT_EQ(e.delivery_bytes_per_s, 20'000);
  for (int i = 0; i < 4; ++i) {  // the link turns out to carry 5 kB/s
    estimator.on_sent(i, 5'000, i * kSecond);
    estimator.on_acked(i, (i + 1) * kSecond);
  }
  e = estimator.estimate(4 * kSecond);
  EXPECT_FALSE(e.from_prior);
  EXPECT_NEAR(e.delivery_bytes_per_s, 5'000, 1);
  DdsLinkProfile radio;
  radio.rate_kbit_s = 250;
  radio.pacing = 0.9;
  EXPECT_NEAR(link_prior_bytes_per_s(radio), 250e3 / 8 * 0.9 / 1.3, 1);
  EXPECT_EQ(link_prior_bytes_per_s(DdsLinkProfile{}), 0.0);
}

TEST(SendLadder, QualityThenResolutionThenDensity) {
  const auto ladder = send_ladder(adaptive(), 85);
  ASSERT_EQ(ladder.size(), 8u);
  EXPECT_EQ(ladder[0], (SendLevel{85, 1.0, 1}));
  EXPECT_EQ(ladder[3], (SendLevel{40, 1.0, 1}));
  EXPECT_EQ(ladder[5], (SendLevel{40, 0.5, 1}));
  EXPECT_EQ(ladder[7], (SendLevel{40, 0.5, 3}));
  // Steps at or above the codec's own quality are not rungs.
  EXPECT_EQ(send_ladder(adaptive(), 60)[1], (SendLevel{55, 1.0, 1}));
}

TEST(SendController, SteadyFastLinkKeepsTheRichestLevel) {
  const Trace trace = fly(
      adaptive(), [](double) { return 120'000.0; }, 60);
  for (const auto level : trace.levels) EXPECT_EQ(level, 0u);
  EXPECT_LT(trace.worst_latency(0, 60), 1.0);
}

TEST(SendController, StepDownLowersTheCostAndKeepsTheLatencyUnderTarget) {
  const auto rate = [](double t) { return t < 30 ? 120'000.0 : 20'000.0; };
  const Trace adapted = fly(adaptive(), rate, 120);
  EXPECT_EQ(adapted.levels[20], 0u);
  EXPECT_GT(adapted.levels[60], 0u);
  // 50 kB a second cannot go over 20 kB/s: the richest level is left within a few seconds and
  // keyframes selected once it settles wait less than the 3 s target.
  EXPECT_LE(adapted.worst_latency(45, 110), 3.0);
  // Without adaptation the same flight's latency grows without bound.
  LinkAdaptationConfig fixed = adaptive();
  fixed.enabled = false;
  const Trace unadapted = fly(fixed, rate, 120);
  EXPECT_GT(unadapted.worst_latency(45, 110), 30.0);
}

TEST(SendController, TheFirstKeyframeCrossesTheLinkWithinHalfTheTarget) {
  // Costs as calibrated on the first frame: 50, 32, 23.5, 18 kB at full size, then scaled.
  const std::vector<double> relative = {1.0, 0.64, 0.47, 0.36, 0.36 * 0.5625, 0.36 * 0.25};
  const auto first_level = [&](double rate) {
    SendController controller(adaptive(), 85);
    for (std::size_t i = 0; i < controller.ladder().size(); ++i)
      controller.on_cost(
          i, static_cast<std::uint64_t>(50'000 * relative[std::min(i, relative.size() - 1)]));
    LinkEstimate prior;
    prior.known = prior.from_prior = true;
    prior.delivery_bytes_per_s = rate;
    controller.update(0, prior, 0);  // before any selection: nothing to decide on
    EXPECT_EQ(controller.level_index(), 0u);
    controller.on_selection(kSecond);
    const auto change = controller.update(kSecond, prior, 0);
    if (controller.level_index() > 0) {
      EXPECT_TRUE(change.has_value());
      EXPECT_NE(change->reason.find("first keyframe"), std::string::npos) << change->reason;
    }
    EXPECT_EQ(controller.level().density, 1);  // never thinned for want of a rate
    return controller.level_index();
  };
  EXPECT_EQ(first_level(120'000.0), 0u);  // 50 kB in 0.4 s
  // 20 kB/s and a 3 s target: 30 kB within 1.5 s, the first rung at most that (23.5 kB).
  EXPECT_EQ(first_level(20'000.0), 2u);
  // 5 kB/s: 7.5 kB, the half-size rung (4.5 kB).
  EXPECT_EQ(first_level(5'000.0), 5u);
}

TEST(SendController, StepUpRaisesTheLevelAgain) {
  const auto rate = [](double t) { return t < 40 ? 15'000.0 : 150'000.0; };
  const Trace trace = fly(adaptive(), rate, 120);
  EXPECT_GT(trace.levels[35], 2u);
  EXPECT_EQ(trace.levels[110], 0u);
  // One step up at a time, each after the link had room for raise_after_s.
  for (std::size_t i = 1; i < trace.levels.size(); ++i) {
    if (trace.levels[i] < trace.levels[i - 1]) {
      EXPECT_EQ(trace.levels[i - 1] - trace.levels[i], 1u);
    }
  }
}

TEST(SendController, OutageGoesToTheCheapestLevelAndRecovers) {
  const auto rate = [](double t) { return t >= 30 && t < 50 ? 0.0 : 80'000.0; };
  const Trace trace = fly(adaptive(), rate, 150);
  EXPECT_EQ(trace.levels[20], 0u);
  EXPECT_EQ(trace.levels[45], send_ladder(adaptive(), 85).size() - 1);
  EXPECT_GT(trace.thinned, 0u);  // the cheapest level thins, and says so
  EXPECT_EQ(trace.levels[145], 0u);
}

}  // namespace
}  // namespace keyfleet::agent

namespace keyfleet::agent {
namespace {

// The sender on a real JPEG codec: a slow link takes it to the scaled rung, where the frame and
// its text regions shrink together and the keyframe costs a fraction of the full one.
TEST(LinkAwareSender, ASlowLinkScalesTheFrameAndItsTextRegions) {
  LinkAdaptationConfig config;
  config.enabled = true;
  config.jpeg_qualities = {};
  config.scales = {0.5};
  config.max_density = 1;
  config.text_aware = false;
  JpegCodec codec(85);
  std::uint64_t backlog = 0;  // what the outbox would say waits
  LinkAwareSender sender(
      config, codec, 85, 0.0, [&backlog] { return backlog; }, keyfleet::null_logger());
  cv::Mat frame(480, 640, CV_8UC3);
  cv::randu(frame, 0, 255);
  const std::vector<TextRegion> regions = {{100, 50, 201, 41}, {600, 440, 40, 40}};
  const std::vector<std::uint8_t> full = codec.encode(frame);
  const auto richest = [&]() -> const std::vector<std::uint8_t>& { return full; };

  auto first = sender.encode(frame, regions, 0, richest);
  EXPECT_FALSE(first.reduced);
  EXPECT_EQ(first.width, 640u);
  EXPECT_EQ(first.text_regions, regions);
  // The link then delivers 10 kB/s while a keyframe a second costs far more.
  for (int i = 0; i < 12; ++i) {
    sender.on_sent(100 + i, 10'000, i * kSecond);
    sender.on_acked(100 + i, (i + 1) * kSecond);
    backlog = full.size() * 3;
    if (i > 0) (void)sender.encode(frame, regions, i * kSecond, richest);
  }
  const auto reduced = sender.encode(frame, regions, 12 * kSecond, richest);
  ASSERT_TRUE(reduced.reduced);
  EXPECT_EQ(reduced.width, 320u);
  EXPECT_EQ(reduced.height, 240u);
  EXPECT_LT(reduced.image.size(), full.size() / 2);
  ASSERT_EQ(reduced.text_regions.size(), 2u);
  EXPECT_EQ(reduced.text_regions[0], (TextRegion{50, 25, 101, 21}));   // rounded outwards
  EXPECT_EQ(reduced.text_regions[1], (TextRegion{300, 220, 20, 20}));  // inside the image
  AgentStats stats;
  sender.fill(stats, 12 * kSecond);
  EXPECT_EQ(stats.send_scale, 0.5);
  EXPECT_GE(stats.level_changes, 1u);
  EXPECT_GE(stats.keyframes_reduced, 1u);
  EXPECT_NEAR(stats.link_bytes_per_s, 10'000, 500);
}

// Text-aware: the scaled rung keeps the frame's size and its text pixels, coarsens the rest.
TEST(LevelEncoding, TextAwareKeepsTheTextSharpAndTheBackgroundCoarse) {
  JpegCodec codec(85);
  cv::Mat frame(480, 640, CV_8UC3);
  cv::randu(frame, 0, 255);  // detail everywhere: the worst case for JPEG
  const std::vector<TextRegion> regions = {{100, 50, 200, 40}};
  const SendLevel level{85, 0.25, 1};
  const auto aware = encode_at_level(frame, regions, level, true, 4, codec);
  const auto scaled = encode_at_level(frame, regions, level, false, 4, codec);
  const auto full = codec.encode(frame);
  EXPECT_EQ(aware.width, 640u);
  EXPECT_EQ(aware.height, 480u);
  EXPECT_EQ(aware.text_regions, regions);
  EXPECT_EQ(scaled.width, 160u);
  EXPECT_EQ(scaled.text_regions[0], (TextRegion{25, 12, 50, 11}));
  // The text region and its margin carry the frame's detail; the background does not.
  const DecodeResult decoded = codec.decode(aware.image);
  ASSERT_TRUE(decoded.ok());
  const auto detail = [](const cv::Mat& image) {
    cv::Mat gray, laplacian;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    cv::Laplacian(gray, laplacian, CV_32F);
    cv::Scalar mean, stddev;
    cv::meanStdDev(laplacian, mean, stddev);
    return stddev[0];
  };
  const cv::Rect text(100, 50, 200, 40), background(300, 300, 200, 100);
  EXPECT_GT(detail(decoded.image(text)), 0.8 * detail(frame(text)));
  EXPECT_LT(detail(decoded.image(background)), 0.3 * detail(frame(background)));
  // Fewer bytes than the full frame, more than the scaled one (the text is all there).
  EXPECT_LT(aware.image.size(), full.size() / 3);
  EXPECT_GT(aware.image.size(), scaled.image.size());
  // Without text regions a text-aware rung sends the scaled frame.
  EXPECT_EQ(encode_at_level(frame, {}, level, true, 4, codec).width, 160u);
}

}  // namespace
}  // namespace keyfleet::agent
