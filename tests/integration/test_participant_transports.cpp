// Which transports a participant runs on, read back from Fast DDS, and what its start-up log
// says about them. Localhost missions run without shared memory unless dds.shared_memory says
// true: a station killed and restarted must not hang on a "zombie" shared-memory port.
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <unistd.h>

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>

#include <memory>
#include <random>
#include <sstream>
#include <string>

#include "dds_participant.hpp"
#include "keyfleet/common/topic_names.hpp"

namespace keyfleet::dds {
namespace {

using eprosima::fastdds::rtps::SharedMemTransportDescriptor;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;

DdsSettings isolated_settings() {
  std::random_device entropy;
  DdsSettings s;
  s.domain_id = static_cast<int>(100 + (static_cast<unsigned>(::getpid()) + entropy()) % 130);
  s.partition = "participant-transports-" + std::to_string(entropy());
  s.security.enabled = false;
  return s;
}

struct Transports {
  bool builtin = false;
  int shared_memory = 0;
  int udp = 0;
  int other = 0;
  std::vector<std::string> udp_interfaces;
};

// The transports of the one participant this process has on `domain_id`, as Fast DDS holds them.
Transports transports_on(int domain_id) {
  auto* participant = fdds::DomainParticipantFactory::get_instance()->lookup_participant(
      static_cast<fdds::DomainId_t>(domain_id));
  EXPECT_NE(participant, nullptr);
  Transports t;
  if (!participant) return t;
  const auto& qos = participant->get_qos().transport();
  t.builtin = qos.use_builtin_transports;
  for (const auto& descriptor : qos.user_transports) {
    if (std::dynamic_pointer_cast<SharedMemTransportDescriptor>(descriptor)) {
      ++t.shared_memory;
    } else if (auto udp = std::dynamic_pointer_cast<UDPv4TransportDescriptor>(descriptor)) {
      ++t.udp;
      t.udp_interfaces.insert(t.udp_interfaces.end(), udp->interfaceWhiteList.begin(),
                              udp->interfaceWhiteList.end());
    } else {
      ++t.other;
    }
  }
  return t;
}

class ParticipantTransports : public ::testing::Test {
 protected:
  Logger logger_ = std::make_shared<spdlog::logger>(
      "test", std::make_shared<spdlog::sinks::ostream_sink_mt>(log_));
  std::ostringstream log_;
};

TEST_F(ParticipantTransports, LocalhostByDefaultIsUdpOnLoopbackWithoutSharedMemory) {
  const DdsSettings settings = isolated_settings();
  ASSERT_EQ(settings.transport, DdsSettings::Transport::kLocalhost);
  ASSERT_FALSE(settings.shared_memory.has_value());
  Participant participant(settings, "transports_test", kStationIdentity, logger_);
  const Transports t = transports_on(settings.domain_id);
  EXPECT_FALSE(t.builtin);
  EXPECT_EQ(t.shared_memory, 0);
  EXPECT_EQ(t.udp, 1);
  EXPECT_EQ(t.other, 0);
  EXPECT_EQ(t.udp_interfaces, std::vector<std::string>{"127.0.0.1"});
  EXPECT_NE(log_.str().find("(localhost only: UDPv4 on 127.0.0.1)"), std::string::npos)
      << log_.str();
}

TEST_F(ParticipantTransports, LocalhostTakesSharedMemoryWhenTheConfigAsksForIt) {
  DdsSettings settings = isolated_settings();
  settings.shared_memory = true;
  Participant participant(settings, "transports_test", kStationIdentity, logger_);
  const Transports t = transports_on(settings.domain_id);
  EXPECT_FALSE(t.builtin);
  EXPECT_EQ(t.shared_memory, 1);
  EXPECT_EQ(t.udp, 1);
  EXPECT_EQ(t.udp_interfaces, std::vector<std::string>{"127.0.0.1"});
  EXPECT_NE(log_.str().find("(localhost only: shared memory + UDPv4 on 127.0.0.1)"),
            std::string::npos)
      << log_.str();
}

TEST_F(ParticipantTransports, NetworkKeepsTheBuiltinTransportsUnlessSharedMemoryIsOff) {
  DdsSettings settings = isolated_settings();
  settings.transport = DdsSettings::Transport::kNetwork;
  {
    Participant participant(settings, "transports_test", kStationIdentity, logger_);
    const Transports t = transports_on(settings.domain_id);
    EXPECT_TRUE(t.builtin);
    EXPECT_EQ(t.shared_memory + t.udp + t.other, 0);
  }
  settings.shared_memory = false;
  Participant participant(settings, "transports_test", kStationIdentity, logger_);
  const Transports t = transports_on(settings.domain_id);
  EXPECT_FALSE(t.builtin);
  EXPECT_EQ(t.shared_memory, 0);
  EXPECT_EQ(t.udp, 1);
  for (const auto& address : t.udp_interfaces) EXPECT_NE(address, "127.0.0.1");
  EXPECT_NE(log_.str().find("(network, shared memory + UDPv4)"), std::string::npos) << log_.str();
  EXPECT_NE(log_.str().find("(network, UDPv4 only)"), std::string::npos) << log_.str();
}

}  // namespace
}  // namespace keyfleet::dds
