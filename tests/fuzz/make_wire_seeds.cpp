// Writes fuzz_wire_conversion's seed corpus: samples made by the adapter's own to_wire and
// serialized by the generated type support, each after fuzz_wire_conversion's topic byte.
//   make_wire_seeds OUT_DIR
#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstdint>
#include <fstream>
#include <iostream>
#include <string>

#include "dds_wire_conversion.hpp"
#include "keyfleetPubSubTypes.h"

namespace {

namespace wire = keyfleet::wire;

template <class Type, class Wire>
void write(const std::string& path, std::uint8_t topic, Wire& sample) {
  Type type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&sample)());
  if (!type.serialize(&sample, &payload)) throw std::runtime_error("cannot serialize " + path);
  std::ofstream out(path, std::ios::binary);
  out.put(static_cast<char>(topic));
  out.write(reinterpret_cast<const char*>(payload.data), payload.length);
  if (!out) throw std::runtime_error("cannot write " + path);
}

keyfleet::Keyframe keyframe(bool full) {
  keyfleet::Keyframe k;
  k.robot_id = "drone_1";
  k.sequence_number = 7;
  k.frame_index = 211;
  k.capture_time_ns = 7033333333;
  k.vslam_keyframe_index = 210;
  k.window_first_frame = 200;
  k.window_last_frame = 215;
  k.quality_score = 0.8;
  k.width = 16;
  k.height = 8;
  // The first and last bytes of a JPEG: the station's checks, not the wire, judge the image.
  k.image = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x04, 0x4A, 0x46, 0xFF, 0xD9};
  if (full) {
    k.camera_pose = keyfleet::Pose{1.5, -2.0, 5.0, 0.0, 0.0, 0.38, 0.92};
    k.text_regions = {{2, 1, 9, 4}, {0, 5, 3, 2}};
  }
  return k;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_wire_seeds OUT_DIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  try {
    for (const bool full : {false, true}) {
      wire::Keyframe w;
      keyfleet::dds::to_wire(keyframe(full), w);
      write<wire::KeyframePubSubType>(dir + (full ? "/keyframe_full" : "/keyframe_plain"), 0, w);
    }
    keyfleet::AgentStats s;
    s.robot_id = "drone_0";
    s.report_time_ns = 12000000000;
    s.finished = true;
    s.frames_seen = 600;
    s.keyframes_sent = 14;
    s.bytes_sent = 180000;
    s.stages = {{"capture", 120.5, 600}, {"select", 40.25, 600}};
    wire::AgentStats ws;
    keyfleet::dds::to_wire(s, ws);
    write<wire::AgentStatsPubSubType>(dir + "/agent_stats", 1, ws);
    keyfleet::KeyframeAck a;
    a.robot_id = "drone_1";
    a.sequence_number = 7;
    a.status = keyfleet::AckStatus::kRejected;
    a.reason = "truncated JPEG: no end-of-image marker";
    wire::KeyframeAck wa;
    keyfleet::dds::to_wire(a, wa);
    write<wire::KeyframeAckPubSubType>(dir + "/ack_rejected", 2, wa);
  } catch (const std::exception& e) {
    std::cerr << "make_wire_seeds: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
