#pragma once
// One DomainParticipant with keyfleet's QoS, owning every entity it creates. Internal.
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <string>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"

namespace keyfleet::dds {

namespace fdds = eprosima::fastdds::dds;

enum class Stream {
  kKeyframes,  // reliable, volatile, KEEP_LAST(depth) on the writer, KEEP_ALL on the reader
  kStats,      // reliable, transient-local, latest few samples
  kAcks,       // reliable, volatile, a deep KEEP_LAST
};

class Participant {
 public:
  Participant(const DdsSettings& settings, const std::string& name, Logger logger);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  fdds::Topic* topic(const std::string& name, fdds::TypeSupport type);
  fdds::DataWriter* writer(fdds::Topic* topic, Stream stream);
  fdds::DataReader* reader(fdds::Topic* topic, Stream stream);

 private:
  DdsSettings settings_;
  Logger logger_;
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Publisher* publisher_ = nullptr;
  fdds::Subscriber* subscriber_ = nullptr;
};

}  // namespace keyfleet::dds
