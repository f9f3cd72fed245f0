#include "dds_participant.hpp"

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/rtps/flowcontrol/FlowControllerDescriptor.hpp>

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "keyfleet/common/error.hpp"
#include "keyfleet/common/security_files.hpp"
#include "keyfleet/dds/link_tuning.hpp"

namespace keyfleet::dds {
namespace {

namespace fs = std::filesystem;

using eprosima::fastrtps::Duration_t;
using eprosima::fastrtps::rtps::IPLocator;
using eprosima::fastrtps::rtps::Locator_t;

constexpr std::uint32_t kShmSegmentBytes = 8u << 20;
constexpr std::uint32_t kUdpBufferBytes = 4u << 20;
constexpr std::uint32_t kMaxInitialPeersRange = 16;
// The link cap: flow-controller periods longer than 10 ms undershot the cap by up to half here.
constexpr char kLinkCapName[] = "keyfleet_link_cap";
constexpr std::uint64_t kLinkCapPeriodMs = 10;
constexpr std::int32_t kCappedWriterSamples = 2;
constexpr long double kCappedWriterBlockingS = 0.005;

// The station's readers of a robot's topics hold at most this many samples (keyless topics: one
// instance), so a writer can make it keep at most that many times limits.max_image_bytes. The
// keyframe depth is above the agents' writer depth (dds.keyframe_history_depth, 5): what a
// writer has in flight fits.
constexpr std::int32_t kKeyframeReaderSamples = 8;
constexpr std::int32_t kStatsReaderSamples = 4;

// The station's acknowledgements stay in its writer's history for a robot whose acknowledgement
// reader matches late: over a lossy radio with DDS-Security the ack path's endpoints can match
// seconds after the keyframe path (seen 7 s at 250 kbit/s with 10 % loss), and an ack written
// before then would be lost to a volatile reader, the keyframe sent again after
// outbox.resend_after_s. 256 are the fleet's last few seconds to tens of seconds of keyframes;
// an ack is about 40 bytes of sample.
constexpr std::int32_t kAckWriterHistory = 256;
constexpr std::int32_t kAckReaderHistory = 1024;

void bound_history(fdds::DataReaderQos& qos, std::int32_t samples) {
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = samples;
  qos.resource_limits().max_samples = samples;
  qos.resource_limits().max_instances = 1;
  qos.resource_limits().max_samples_per_instance = samples;
  qos.resource_limits().allocated_samples = std::min<std::int32_t>(samples, 2);
}

Locator_t udp_locator(const std::string& address) {
  Locator_t locator;
  locator.kind = LOCATOR_KIND_UDPv4;
  if (!IPLocator::setIPv4(locator, address) || !IPLocator::isIPv4(address))
    throw StartupError("dds.initial_peers: '" + address + "' is not an IPv4 address");
  return locator;
}

std::vector<std::string> non_loopback_ipv4_addresses() {
  std::vector<std::string> addresses;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return addresses;
  for (const ifaddrs* it = list; it; it = it->ifa_next) {
    if (!it->ifa_addr || it->ifa_addr->sa_family != AF_INET || (it->ifa_flags & IFF_LOOPBACK))
      continue;
    char text[INET_ADDRSTRLEN] = {};
    const auto* in = reinterpret_cast<const sockaddr_in*>(it->ifa_addr);
    if (::inet_ntop(AF_INET, &in->sin_addr, text, sizeof text)) addresses.emplace_back(text);
  }
  ::freeifaddrs(list);
  return addresses;
}

// dds.shared_memory, unset: off on localhost (config.hpp says why), on with the network's
// built-in transports.
bool uses_shared_memory(const DdsSettings& s) {
  return s.shared_memory.value_or(s.transport == DdsSettings::Transport::kNetwork);
}

// What the participant runs on, for the start-up log.
std::string transports(const DdsSettings& s) {
  const bool shm = uses_shared_memory(s);
  if (s.transport == DdsSettings::Transport::kLocalhost)
    return shm ? "localhost only: shared memory + UDPv4 on 127.0.0.1"
               : "localhost only: UDPv4 on 127.0.0.1";
  return shm ? "network, shared memory + UDPv4" : "network, UDPv4 only";
}

std::optional<LinkTuning> link_tuning(const DdsSettings& s) {
  if (s.link.rate_kbit_s > 0)
    return derive_link_tuning(s.link, s.security.enabled ? &kFleetGovernance : nullptr);
  return std::nullopt;
}

std::shared_ptr<eprosima::fastdds::rtps::FlowControllerDescriptor> link_cap(
    std::uint64_t period_ms, std::uint64_t bytes_per_period) {
  auto cap = std::make_shared<eprosima::fastdds::rtps::FlowControllerDescriptor>();
  cap->name = kLinkCapName;
  cap->scheduler = eprosima::fastdds::rtps::FlowControllerSchedulerPolicy::FIFO;
  cap->period_ms = period_ms;
  cap->max_bytes_per_period = static_cast<std::int32_t>(
      std::clamp<std::uint64_t>(bytes_per_period, 1, std::numeric_limits<std::int32_t>::max()));
  return cap;
}

fdds::DomainParticipantQos participant_qos(const DdsSettings& s, const std::string& name,
                                           const std::string& identity,
                                           const std::optional<LinkTuning>& tuning) {
  fdds::DomainParticipantQos qos = fdds::PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  if (s.security.enabled)
    for (auto& [key, value] : security_properties(s, identity))
      qos.properties().properties().emplace_back(key, value);
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  discovery.leaseDuration =
      Duration_t(static_cast<long double>(tuning ? tuning->lease_duration_s : s.lease_duration_s));
  discovery.leaseDuration_announcementperiod = Duration_t(
      static_cast<long double>(tuning ? tuning->announcement_period_s : s.announcement_period_s));

  if (s.transport == DdsSettings::Transport::kLocalhost) {
    // No built-in transports: the defaults announce on every interface by multicast.
    qos.transport().use_builtin_transports = false;
    if (uses_shared_memory(s)) {
      auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
      shm->segment_size(kShmSegmentBytes);
      qos.transport().user_transports.push_back(shm);
    }
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.emplace_back("127.0.0.1");
    udp->sendBufferSize = kUdpBufferBytes;
    udp->receiveBufferSize = kUdpBufferBytes;
    udp->maxInitialPeersRange = kMaxInitialPeersRange;
    qos.transport().user_transports.push_back(udp);
    qos.wire_protocol().builtin.initialPeersList.push_back(udp_locator("127.0.0.1"));
    qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(udp_locator("127.0.0.1"));
  } else {
    if (!uses_shared_memory(s)) {
      // Built-in transports include shared memory, which crosses network namespaces.
      qos.transport().use_builtin_transports = false;
      auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
      udp->sendBufferSize = kUdpBufferBytes;
      udp->receiveBufferSize = kUdpBufferBytes;
      // An initial peer without a port stands for this many participants on its host, each
      // announced to: over a radio, only the first (one keyfleet process per host).
      udp->maxInitialPeersRange = tuning ? 1 : kMaxInitialPeersRange;
      // Loopback carries nothing between namespaces, but announcing it makes a peer in another
      // namespace (with the same ports) talk to itself: only the real interfaces.
      const auto addresses = non_loopback_ipv4_addresses();
      for (const auto& address : addresses) udp->interfaceWhiteList.push_back(address);
      qos.transport().user_transports.push_back(udp);
      // On a radio link discovery goes to the configured peers only: with a unicast
      // metatraffic locator of its own, Fast DDS neither joins nor announces to its multicast
      // group, whose announcements would cross the link a second time.
      if (tuning && !s.initial_peers.empty())
        for (const auto& address : addresses)
          qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(udp_locator(address));
    }
    for (const auto& peer : s.initial_peers)
      qos.wire_protocol().builtin.initialPeersList.push_back(udp_locator(peer));
  }
  if (tuning)
    qos.flow_controllers().push_back(
        link_cap(tuning->flow_period_ms, tuning->flow_bytes_per_period));
  else if (s.max_bytes_per_s > 0)
    qos.flow_controllers().push_back(
        link_cap(kLinkCapPeriodMs, s.max_bytes_per_s * kLinkCapPeriodMs / 1000));
  return qos;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> security_properties(const DdsSettings& settings,
                                                                     const std::string& identity) {
  require_security_credentials(settings.security, identity);
  const SecurityFiles files = security_files(settings.security.directory, identity);
  const std::string auth = "dds.sec.auth.builtin.PKI-DH.";
  const std::string access = "dds.sec.access.builtin.Access-Permissions.";
  std::vector<std::pair<std::string, std::string>> properties{
      {"dds.sec.auth.plugin", "builtin.PKI-DH"},
      {auth + "identity_ca", "file://" + files.ca},
      {auth + "identity_certificate", "file://" + files.certificate},
      {auth + "private_key", "file://" + files.private_key},
      {"dds.sec.access.plugin", "builtin.Access-Permissions"},
      {access + "permissions_ca", "file://" + files.ca},
      {access + "governance", "file://" + files.governance},
      {access + "permissions", "file://" + files.permissions},
      {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"}};
  // Withdrawn robots (`keyfleet security withdraw`): Fast DDS 2.9's PKI-DH checks each peer's
  // certificate against this CRL in the handshake, so a withdrawn robot is never authenticated.
  if (fs::is_regular_file(files.crl))
    properties.emplace_back(auth + "identity_crl", "file://" + files.crl);
  return properties;
}

Participant::Participant(const DdsSettings& settings, const std::string& name,
                         const std::string& identity, Logger logger,
                         fdds::DomainParticipantListener* listener)
    : settings_(settings), tuning_(link_tuning(settings)), logger_(std::move(logger)) {
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  participant_ = factory->create_participant(static_cast<fdds::DomainId_t>(settings.domain_id),
                                             participant_qos(settings, name, identity, tuning_),
                                             listener, fdds::StatusMask::none());
  if (!participant_)
    throw StartupError(
        "cannot create DDS participant on domain " + std::to_string(settings.domain_id) +
        (settings.security.enabled
             ? " with DDS-Security identity '" + identity + "' from " + settings.security.directory
             : std::string()) +
        " (see the Fast DDS errors above)");
  fdds::PublisherQos pub_qos = fdds::PUBLISHER_QOS_DEFAULT;
  pub_qos.partition().push_back(settings.partition.c_str());
  publisher_ = participant_->create_publisher(pub_qos);
  fdds::SubscriberQos sub_qos = fdds::SUBSCRIBER_QOS_DEFAULT;
  sub_qos.partition().push_back(settings.partition.c_str());
  subscriber_ = participant_->create_subscriber(sub_qos);
  if (!publisher_ || !subscriber_) {
    factory->delete_participant(participant_);
    throw StartupError("cannot create DDS publisher/subscriber for partition '" +
                       settings.partition + "'");
  }
  logger_->info("DDS participant '{}' on domain {} partition '{}' ({}{})", name, settings.domain_id,
                settings.partition, transports(settings),
                settings.security.enabled ? "; DDS-Security as '" + identity + "'" : std::string());
  if (tuning_)
    logger_->info("{}", describe(settings.link, *tuning_));
  else if (settings.max_bytes_per_s > 0)
    logger_->info("keyframe writer capped at {} bytes/s (flow controller, {} ms periods)",
                  settings.max_bytes_per_s, kLinkCapPeriodMs);
}

Participant::~Participant() {
  if (!participant_) return;
  participant_->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
}

fdds::Topic* Participant::topic(const std::string& name, fdds::TypeSupport type) {
  if (auto it = topics_.find(name); it != topics_.end()) return it->second;
  if (type.register_type(participant_) != ReturnCode_t::RETCODE_OK)
    throw StartupError("cannot register DDS type " + type.get_type_name());
  fdds::Topic* topic =
      participant_->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (!topic) throw StartupError("cannot create DDS topic " + name);
  topics_.emplace(name, topic);
  return topic;
}

fdds::DataWriter* Participant::writer(fdds::Topic* topic, Stream stream) {
  fdds::DataWriterQos qos = publisher_->get_default_datawriter_qos();
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  qos.data_sharing().off();
  qos.reliable_writer_qos().times.heartbeatPeriod = Duration_t(static_cast<long double>(
      tuning_ ? tuning_->heartbeat_period_s : settings_.heartbeat_period_s));
  if (tuning_) {
    // A NACK is answered at once: on a slow link a repair waits behind data anyway.
    qos.reliable_writer_qos().times.nackResponseDelay = Duration_t(0, 0);
    // Fast DDS piggybacks a heartbeat on every message while the history is full (a capped
    // writer's two samples: most of the time), and each one draws an acknack: 32 bytes more per
    // message one way, a message back. The periodic heartbeat above suffices.
    qos.reliable_writer_qos().disable_heartbeat_piggyback = true;
  }
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  switch (stream) {
    case Stream::kKeyframes:
      qos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
      qos.history().depth = settings_.keyframe_history_depth;
      if (tuning_ || settings_.max_bytes_per_s > 0) {
        // Under a cap a small KEEP_LAST starves and a deep queue only adds latency: keep
        // two samples and refuse a write quickly, the outbox sends it again later.
        qos.publish_mode().kind = fdds::ASYNCHRONOUS_PUBLISH_MODE;
        qos.publish_mode().flow_controller_name = kLinkCapName;
        qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
        qos.resource_limits().max_samples = kCappedWriterSamples;
        qos.resource_limits().max_samples_per_instance = kCappedWriterSamples;
        qos.resource_limits().allocated_samples = kCappedWriterSamples;
        qos.reliability().max_blocking_time = Duration_t(kCappedWriterBlockingS);
      }
      break;
    case Stream::kStats:
      qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      qos.history().depth = 1;
      if (tuning_) {
        // Through the link's pacing too: a stats sample sent past it would queue in the radio.
        qos.publish_mode().kind = fdds::ASYNCHRONOUS_PUBLISH_MODE;
        qos.publish_mode().flow_controller_name = kLinkCapName;
      }
      break;
    case Stream::kAcks:
      qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      qos.history().depth = kAckWriterHistory;
      break;
  }
  fdds::DataWriter* writer = publisher_->create_datawriter(topic, qos);
  if (!writer) throw StartupError("cannot create DDS writer on " + topic->get_name());
  // The entity id names this writer's submessages on the wire (a capture's accounting reads it).
  const auto& id = writer->guid().entityId.value;
  logger_->info("DDS writer on '{}': entity {:02x}{:02x}{:02x}.{:02x}", topic->get_name(), id[0],
                id[1], id[2], id[3]);
  return writer;
}

fdds::DataReader* Participant::reader(fdds::Topic* topic, Stream stream) {
  fdds::DataReaderQos qos = subscriber_->get_default_datareader_qos();
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  qos.data_sharing().off();
  switch (stream) {
    case Stream::kKeyframes:
      // A few samples per robot, whatever their writer sends: a keyframe overwritten before the
      // station takes it is never acknowledged, and the agent's outbox sends it again.
      qos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
      bound_history(qos, kKeyframeReaderSamples);
      break;
    case Stream::kStats:
      qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      bound_history(qos, kStatsReaderSamples);
      break;
    case Stream::kAcks:
      qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
      qos.history().depth = kAckReaderHistory;
      break;
  }
  fdds::DataReader* reader = subscriber_->create_datareader(topic, qos);
  if (!reader) throw StartupError("cannot create DDS reader on " + topic->get_name());
  reader->get_statuscondition().set_enabled_statuses(fdds::StatusMask::data_available());
  return reader;
}

}  // namespace keyfleet::dds
