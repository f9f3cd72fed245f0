#pragma once
// One DomainParticipant with keyfleet's QoS, owning every entity it creates. Internal.
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/dds/link_tuning.hpp"

namespace keyfleet::dds {

namespace fdds = eprosima::fastdds::dds;

enum class Stream {
  kKeyframes,  // reliable, volatile, KEEP_LAST(depth) on the writer, KEEP_LAST 8 on the reader
  kStats,      // reliable, transient-local, latest few samples (4 on the reader)
  kAcks,       // reliable, transient-local: the station's recent acknowledgements reach a robot
               // whose reader matched after they were written (each names the sample it
               // answers, so a robot takes only those of its current keyframe writer)
};

class Participant {
 public:
  // `identity`: the DDS-Security identity when settings.security.enabled (a robot id, or
  // kStationIdentity). `listener` (may be null) hears discovery only, never data.
  Participant(const DdsSettings& settings, const std::string& name, const std::string& identity,
              Logger logger, fdds::DomainParticipantListener* listener = nullptr);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  // The topic of that name, created on first use.
  fdds::Topic* topic(const std::string& name, fdds::TypeSupport type);
  fdds::DataWriter* writer(fdds::Topic* topic, Stream stream);
  fdds::DataReader* reader(fdds::Topic* topic, Stream stream);

 private:
  DdsSettings settings_;
  std::optional<LinkTuning> tuning_;  // a radio link's derived settings, if any
  Logger logger_;
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Publisher* publisher_ = nullptr;
  fdds::Subscriber* subscriber_ = nullptr;
  std::map<std::string, fdds::Topic*> topics_;
};

// The Fast DDS properties that turn DDS-Security on for `identity`, from the files of
// `keyfleet security init` in settings.security.directory; throws StartupError naming a
// missing file.
std::vector<std::pair<std::string, std::string>> security_properties(const DdsSettings& settings,
                                                                     const std::string& identity);

}  // namespace keyfleet::dds
