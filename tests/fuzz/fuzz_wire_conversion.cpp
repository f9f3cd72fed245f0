// What the station does with a DDS sample's bytes: the adapter's type support (Fast CDR into
// the generated wire type) deserializes them, as the reader does in take(), and the adapter
// converts that to the domain type. The first byte picks the topic: keyframes, agent stats or
// acknowledgements. A sample that deserializes converts, and the converted value, sent again, reads
// back the same (strings up to their first NUL: Fast CDR writes a string as a C string, so a
// hostile sample's string with a NUL inside comes back cut there).
#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "dds_checked_type.hpp"
#include "dds_wire_conversion.hpp"
#include "keyfleetPubSubTypes.h"

namespace {

using eprosima::fastrtps::rtps::SerializedPayload_t;
namespace wire = keyfleet::wire;

std::string cdr_text(const std::string& s) { return s.substr(0, s.find('\0')); }

template <class Type, class Wire>
bool read(const std::uint8_t* data, std::size_t size, Wire& out) {
  SerializedPayload_t payload(static_cast<std::uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, data, size);
  payload.length = static_cast<std::uint32_t>(size);
  keyfleet::dds::CheckedType<Type> type;
  return type.deserialize(&payload, &out);
}

template <class Type, class Wire>
Wire send_again(Wire& sample) {
  Type type;
  SerializedPayload_t payload(type.getSerializedSizeProvider(&sample)());
  if (!type.serialize(&sample, &payload)) std::abort();
  Wire back;
  if (!type.deserialize(&payload, &back)) std::abort();
  return back;
}

void keyframe(const std::uint8_t* data, std::size_t size) {
  wire::Keyframe sample;
  if (!read<wire::KeyframePubSubType>(data, size, sample)) return;
  const keyfleet::Keyframe k = keyfleet::dds::from_wire(std::move(sample));
  wire::Keyframe out;
  keyfleet::dds::to_wire(k, out);
  const keyfleet::Keyframe again =
      keyfleet::dds::from_wire(send_again<wire::KeyframePubSubType>(out));
  if (again.robot_id != cdr_text(k.robot_id) || again.sequence_number != k.sequence_number ||
      again.encoding != cdr_text(k.encoding) || again.width != k.width ||
      again.height != k.height || again.image != k.image || again.text_regions != k.text_regions ||
      again.camera_pose.has_value() != k.camera_pose.has_value())
    std::abort();
}

void stats(const std::uint8_t* data, std::size_t size) {
  wire::AgentStats sample;
  if (!read<wire::AgentStatsPubSubType>(data, size, sample)) return;
  const keyfleet::AgentStats s = keyfleet::dds::from_wire(sample);
  wire::AgentStats out;
  keyfleet::dds::to_wire(s, out);
  const keyfleet::AgentStats again =
      keyfleet::dds::from_wire(send_again<wire::AgentStatsPubSubType>(out));
  if (again.robot_id != cdr_text(s.robot_id) || again.frames_seen != s.frames_seen ||
      again.stages.size() != s.stages.size())
    std::abort();
  for (std::size_t i = 0; i < s.stages.size(); ++i)
    if (again.stages[i].stage != cdr_text(s.stages[i].stage) ||
        again.stages[i].calls != s.stages[i].calls)
      std::abort();
}

void ack(const std::uint8_t* data, std::size_t size) {
  wire::KeyframeAck sample;
  if (!read<wire::KeyframeAckPubSubType>(data, size, sample)) return;
  const keyfleet::KeyframeAck a = keyfleet::dds::from_wire(sample);
  wire::KeyframeAck out;
  keyfleet::dds::to_wire(a, out);
  const keyfleet::KeyframeAck again =
      keyfleet::dds::from_wire(send_again<wire::KeyframeAckPubSubType>(out));
  if (again.robot_id != cdr_text(a.robot_id) || again.status != a.status ||
      again.reason != cdr_text(a.reason))
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  switch (data[0] % 3) {
    case 0: keyframe(data + 1, size - 1); break;
    case 1: stats(data + 1, size - 1); break;
    default: ack(data + 1, size - 1); break;
  }
  return 0;
}
