// The station's readers of a robot's topics hold a few samples, one instance, whatever the
// writer sends: their QoS as Fast DDS reports it back.
#include <gtest/gtest.h>
#include <unistd.h>

#include <random>

#include "dds_participant.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleetPubSubTypes.h"

namespace keyfleet::dds {
namespace {

DdsSettings isolated_settings() {
  std::random_device entropy;
  DdsSettings s;
  s.domain_id = static_cast<int>(100 + (static_cast<unsigned>(::getpid()) + entropy()) % 130);
  s.partition = "station-readers-" + std::to_string(entropy());
  s.security.enabled = false;
  return s;
}

void expect_bounded(fdds::DataReader* reader, std::int32_t samples) {
  ASSERT_NE(reader, nullptr);
  const fdds::DataReaderQos qos = reader->get_qos();
  EXPECT_EQ(qos.history().kind, fdds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(qos.history().depth, samples);
  EXPECT_EQ(qos.resource_limits().max_samples, samples);
  EXPECT_EQ(qos.resource_limits().max_samples_per_instance, samples);
  EXPECT_EQ(qos.resource_limits().max_instances, 1);
  EXPECT_EQ(qos.reliability().kind, fdds::RELIABLE_RELIABILITY_QOS);
}

TEST(StationReaders, KeyframeAndStatsReadersKeepFewSamples) {
  Participant participant(isolated_settings(), "readers_test", kStationIdentity, null_logger());
  const fdds::TypeSupport keyframes(new wire::KeyframePubSubType());
  const fdds::TypeSupport stats(new wire::AgentStatsPubSubType());
  expect_bounded(
      participant.reader(participant.topic(std::string(kKeyframeTopicPrefix) + "r1", keyframes),
                         Stream::kKeyframes),
      8);
  expect_bounded(
      participant.reader(participant.topic(std::string(kAgentStatsTopicPrefix) + "r1", stats),
                         Stream::kStats),
      4);
}

}  // namespace
}  // namespace keyfleet::dds
