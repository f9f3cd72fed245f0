#pragma once
// The generated type support, made safe against hostile bytes. Internal to the DDS adapter.
#include <fastdds/rtps/common/SerializedPayload.h>

#include <exception>

namespace keyfleet::dds {

// fastddsgen's deserialize catches only a too-short buffer: a sample with another encapsulation
// (Fast CDR's BadParamException) or a sequence longer than memory (std::bad_alloc) throws out of
// DataReader::take_next_sample into the station's or the agent's loop. Here such a sample is
// refused like a short one: deserialize returns false and Fast DDS drops the sample.
template <class Generated>
class CheckedType final : public Generated {
 public:
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    try {
      return Generated::deserialize(payload, data);
    } catch (const std::exception&) {  // Fast CDR's exceptions are std::exceptions too
      return false;
    }
  }
};

}  // namespace keyfleet::dds
