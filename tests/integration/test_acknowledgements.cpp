// The station's acknowledgements over real DDS: one written before a robot's reader matched still
// reaches it (over a lossy radio with DDS-Security the acknowledgement path can match seconds
// after the keyframe path), and a robot takes only those of its current writer's samples, never
// one the station kept from an earlier participant of the same robot.
#include <gtest/gtest.h>

#include <optional>

#include "dds_participant.hpp"
#include "keyfleet/common/topic_names.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleetPubSubTypes.h"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::seconds;

class Acknowledgements : public FleetFixture {
 protected:
  // Publishes `k` once the link has a station, until it takes an answer to its number.
  static std::optional<KeyframeAck> publish_until_acknowledged(AgentLink& link, const Keyframe& k) {
    if (!wait_until([&] { return link.matched_stations() > 0; }, seconds(20))) return std::nullopt;
    return first_answer(link, k, seconds(30));
  }
};

TEST_F(Acknowledgements, AnAcknowledgementWrittenBeforeTheReaderMatchedReachesIt) {
  DdsSettings settings = dds();
  dds::Participant station(settings, "ack_writer", kStationIdentity, null_logger());
  const eprosima::fastdds::dds::TypeSupport type(new wire::KeyframeAckPubSubType());
  auto* writer = station.writer(station.topic(kKeyframeAckTopic, type), dds::Stream::kAcks);
  wire::KeyframeAck sample;
  sample.robot_id("late_drone");
  sample.sequence_number(7);
  ASSERT_TRUE(writer->write(&sample));

  dds::Participant robot(settings, "ack_reader", "late_drone", null_logger());
  auto* reader = robot.reader(robot.topic(kKeyframeAckTopic, type), dds::Stream::kAcks);
  wire::KeyframeAck taken;
  eprosima::fastdds::dds::SampleInfo info;
  EXPECT_TRUE(wait_until(
      [&] {
        return reader->take_next_sample(&taken, &info) == ReturnCode_t::RETCODE_OK &&
               info.valid_data;
      },
      seconds(20)))
      << "the acknowledgement written before the reader existed never reached it";
  EXPECT_EQ(taken.robot_id(), "late_drone");
  EXPECT_EQ(taken.sequence_number(), 7u);
}

// A robot that lost its outbox starts its numbers again: the station holds number 0 with another
// image and answers `conflict`. Its history still holds the `stored` it sent the robot's earlier
// participant for number 0; taken by the new one, that would drop the new keyframe unsent.
TEST_F(Acknowledgements, ARobotTakesOnlyAcknowledgementsOfItsCurrentWritersSamples) {
  auto station = start_station(station_config());
  {
    auto earlier = make_dds_agent_link(dds(), "drone", null_logger());
    const auto ack = publish_until_acknowledged(*earlier, small_keyframe("drone", 0, 40));
    ASSERT_TRUE(ack.has_value()) << "the first participant's keyframe was never acknowledged";
    EXPECT_EQ(ack->status, AckStatus::kStored) << ack->reason;
  }
  auto later = make_dds_agent_link(dds(), "drone", null_logger());
  const auto ack = publish_until_acknowledged(*later, small_keyframe("drone", 0, 90));
  ASSERT_TRUE(ack.has_value()) << "the second participant's keyframe was never answered";
  EXPECT_EQ(ack->status, AckStatus::kConflict)
      << "the new participant took the acknowledgement of the earlier one's keyframe";
  EXPECT_EQ(stored_counts()["drone"], 1);
}

}  // namespace
}  // namespace keyfleet::testing
