// The DDS adapter's type support on hostile samples: what the generated code lets throw out of
// DataReader::take_next_sample (found by tests/fuzz/fuzz_wire_conversion) is refused instead.
#include <gtest/gtest.h>

#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dds_checked_type.hpp"
#include "dds_wire_conversion.hpp"
#include "keyfleetPubSubTypes.h"

namespace keyfleet {
namespace {

using eprosima::fastrtps::rtps::SerializedPayload_t;

std::vector<std::uint8_t> serialized_keyframe() {
  Keyframe k;
  k.robot_id = "drone_1";
  k.width = 16;
  k.height = 8;
  k.image = {0xFF, 0xD8, 0xFF, 0xD9};
  k.text_regions = {{1, 2, 3, 4}};
  wire::Keyframe sample;
  dds::to_wire(k, sample);
  wire::KeyframePubSubType type;
  SerializedPayload_t payload(type.getSerializedSizeProvider(&sample)());
  EXPECT_TRUE(type.serialize(&sample, &payload));
  return {payload.data, payload.data + payload.length};
}

bool deserialize(eprosima::fastdds::dds::TopicDataType& type,
                 const std::vector<std::uint8_t>& bytes, wire::Keyframe& out) {
  SerializedPayload_t payload(static_cast<std::uint32_t>(bytes.size()));
  std::copy(bytes.begin(), bytes.end(), payload.data);
  payload.length = static_cast<std::uint32_t>(bytes.size());
  return type.deserialize(&payload, &out);
}

TEST(CheckedType, ReadsAWellFormedSample) {
  dds::CheckedType<wire::KeyframePubSubType> type;
  wire::Keyframe sample;
  ASSERT_TRUE(deserialize(type, serialized_keyframe(), sample));
  const Keyframe k = dds::from_wire(std::move(sample));
  EXPECT_EQ(k.robot_id, "drone_1");
  EXPECT_EQ(k.image.size(), 4u);
  EXPECT_EQ(k.text_regions.size(), 1u);
}

TEST(CheckedType, RefusesAnotherEncapsulationThatTheGeneratedCodeThrowsOn) {
  std::vector<std::uint8_t> bytes = serialized_keyframe();
  bytes[0] = 0xD1;  // the encapsulation's first byte must be 0
  wire::Keyframe sample;
  wire::KeyframePubSubType generated;
  EXPECT_ANY_THROW(deserialize(generated, bytes, sample));
  dds::CheckedType<wire::KeyframePubSubType> checked;
  EXPECT_FALSE(deserialize(checked, bytes, sample));
}

TEST(CheckedType, RefusesTruncatedSamples) {
  const std::vector<std::uint8_t> bytes = serialized_keyframe();
  dds::CheckedType<wire::KeyframePubSubType> type;
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    wire::Keyframe sample;
    EXPECT_FALSE(deserialize(type, {bytes.begin(), bytes.begin() + std::ptrdiff_t(n)}, sample))
        << n;
  }
}

}  // namespace
}  // namespace keyfleet
