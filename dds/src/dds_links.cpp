// AgentLink and StationLink over Fast DDS: the only place that moves bytes on the wire.
#include <fastrtps/rtps/common/WriteParams.h>
#include <fastdds/dds/core/condition/GuardCondition.hpp>
#include <fastdds/dds/core/condition/WaitSet.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include <algorithm>
#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "dds_checked_type.hpp"
#include "dds_participant.hpp"
#include "dds_wire_conversion.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/common/printable_text.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleetPubSubTypes.h"

namespace keyfleet {
namespace {

using dds::Participant;
using dds::Stream;
namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::Duration_t;
using eprosima::fastrtps::rtps::SampleIdentity;
using eprosima::fastrtps::rtps::WriteParams;

Duration_t to_duration(std::chrono::milliseconds ms) {
  return Duration_t(static_cast<long double>(ms.count()) / 1000.0L);
}

// Waits until one of `readers` has unread data, or `wait` passes (or another condition of the
// waitset triggers).
void wait_for_data(fdds::WaitSet& waitset, const std::vector<fdds::DataReader*>& readers,
                   std::chrono::milliseconds wait) {
  for (auto* reader : readers)
    if (reader->get_unread_count() > 0) return;
  if (wait.count() <= 0) return;
  fdds::ConditionSeq active;
  waitset.wait(active, to_duration(wait));
}

// One participant with the agent's writers and reader; replaced whole when the agent rejoins.
struct AgentSession {
  AgentSession(const DdsSettings& settings, const std::string& robot_id, Logger logger)
      : participant(settings, "keyfleet_agent", robot_id, std::move(logger)),
        keyframe_type(new dds::CheckedType<wire::KeyframePubSubType>()),
        stats_type(new dds::CheckedType<wire::AgentStatsPubSubType>()),
        ack_type(new dds::CheckedType<wire::KeyframeAckPubSubType>()) {
    keyframe_writer = participant.writer(
        participant.topic(kKeyframeTopicPrefix + robot_id, keyframe_type), Stream::kKeyframes);
    stats_writer = participant.writer(
        participant.topic(kAgentStatsTopicPrefix + robot_id, stats_type), Stream::kStats);
    ack_reader = participant.reader(participant.topic(kKeyframeAckTopic, ack_type), Stream::kAcks);
    waitset.attach_condition(ack_reader->get_statuscondition());
  }
  ~AgentSession() { waitset.detach_condition(ack_reader->get_statuscondition()); }

  Participant participant;
  fdds::TypeSupport keyframe_type;
  fdds::TypeSupport stats_type;
  fdds::TypeSupport ack_type;
  fdds::DataWriter* keyframe_writer = nullptr;
  fdds::DataWriter* stats_writer = nullptr;
  fdds::DataReader* ack_reader = nullptr;
  fdds::WaitSet waitset;
};

class DdsAgentLink final : public AgentLink {
 public:
  DdsAgentLink(const DdsSettings& settings, const std::string& robot_id, Logger logger)
      : settings_(settings),
        robot_id_(robot_id),
        logger_(std::move(logger)),
        session_(std::make_unique<AgentSession>(settings_, robot_id_, logger_)),
        last_matched_(std::chrono::steady_clock::now()) {}

  PublishResult publish(const Keyframe& keyframe) override {
    dds::to_wire(keyframe, keyframe_sample_);
    return write(session_->keyframe_writer, session_->keyframe_type, keyframe_sample_);
  }

  PublishResult publish(const AgentStats& stats) override {
    dds::to_wire(stats, stats_sample_);
    return write(session_->stats_writer, session_->stats_type, stats_sample_);
  }

  std::uint64_t serialized_size(const Keyframe& keyframe) const override {
    wire::Keyframe sample;
    dds::to_wire(keyframe, sample);
    auto type = session_->keyframe_type;
    return type->getSerializedSizeProvider(&sample)();
  }

  std::size_t matched_stations() const override {
    fdds::PublicationMatchedStatus status;
    session_->keyframe_writer->get_publication_matched_status(status);
    return static_cast<std::size_t>(status.current_count);
  }

  std::vector<KeyframeAck> take_acks(const std::string& robot_id,
                                     std::chrono::milliseconds wait) override {
    rejoin_if_alone();
    wait_for_data(session_->waitset, {session_->ack_reader}, wait);
    std::vector<KeyframeAck> acks;
    wire::KeyframeAck sample;
    fdds::SampleInfo info;
    // An acknowledgement names the keyframe sample it answers. The station keeps its recent
    // ones for readers that match late, so this reader also gets those of an earlier
    // participant or process of this robot (before a rejoin or a restart): they answered
    // samples of another writer, perhaps with another image under the same number, and are
    // not taken for this writer's.
    const auto& writer = session_->keyframe_writer->guid();
    std::size_t foreign = 0;
    while (session_->ack_reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data || sample.robot_id() != robot_id) continue;
      if (info.related_sample_identity.writer_guid() != writer) {
        ++foreign;
        continue;
      }
      acks.push_back(dds::from_wire(sample));
    }
    if (foreign > 0)
      logger_->debug("{} acknowledgement(s) of an earlier writer's keyframes not taken", foreign);
    return acks;
  }

  bool flush_stats(std::chrono::milliseconds timeout) override {
    return session_->stats_writer->wait_for_acknowledgments(to_duration(timeout)) ==
           ReturnCode_t::RETCODE_OK;
  }

 private:
  // Over a lossy radio Fast DDS 2.9.1 can leave a handshake half done for good: the requester
  // sent its final message, which was lost, and resends it only on a reply that the replier has
  // stopped sending (seen at 100 kbit/s with 20 % loss: the station authenticated, the robot
  // never). A robot without a station for dds.link.rejoin_after_s joins again as a new
  // participant; what its writer held is sent again by the outbox.
  void rejoin_if_alone() {
    const double after_s = settings_.link.rate_kbit_s > 0 ? settings_.link.rejoin_after_s : 0;
    if (after_s <= 0) return;
    const auto now = std::chrono::steady_clock::now();
    if (matched_stations() > 0) {
      if (rejoined_unmatched_) logger_->info("station matched after rejoining ({})", rejoins_);
      rejoined_unmatched_ = false;
      last_matched_ = now;
      return;
    }
    if (now - last_matched_ < std::chrono::duration<double>(after_s)) return;
    logger_->warn(
        "no station matched for {:g} s: joining the DDS domain again as a new "
        "participant (rejoin {})",
        after_s, ++rejoins_);
    session_.reset();  // the old participant leaves before the new one announces itself
    session_ = std::make_unique<AgentSession>(settings_, robot_id_, logger_);
    rejoined_unmatched_ = true;
    last_matched_ = now;
  }

  template <class Wire>
  PublishResult write(fdds::DataWriter* writer, fdds::TypeSupport& type, Wire& sample) {
    PublishResult result;
    result.serialized_bytes = type->getSerializedSizeProvider(&sample)();
    result.ok = writer->write(&sample);
    if (!result.ok) result.error = "DDS write failed on " + writer->get_topic()->get_name();
    return result;
  }

  DdsSettings settings_;
  std::string robot_id_;
  Logger logger_;
  std::unique_ptr<AgentSession> session_;
  std::chrono::steady_clock::time_point last_matched_;
  unsigned rejoins_ = 0;
  bool rejoined_unmatched_ = false;  // the match after a rejoin is logged once
  wire::Keyframe keyframe_sample_;
  wire::AgentStats stats_sample_;
};

// Hears the robots' keyframe and stats writers being discovered; the station link subscribes to
// their topics from its own thread (Fast DDS entities are not created inside its callbacks).
// Only robots that `admission` admits are taken (it logs each refused one once): the robots
// announced are bounded by limits.max_robots, and nothing is kept for a refused one.
class RobotTopicDiscovery final : public fdds::DomainParticipantListener {
 public:
  RobotTopicDiscovery(std::string partition, std::shared_ptr<RobotAdmission> admission)
      : partition_(std::move(partition)), admission_(std::move(admission)) {}

  void on_publisher_discovery(fdds::DomainParticipant*,
                              eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    // Writers of every partition on the domain are announced; another mission's are not ours.
    const auto partitions = info.info.m_qos.m_partition.names();
    if (std::find(partitions.begin(), partitions.end(), partition_) == partitions.end()) return;
    const std::string topic = info.info.topicName().to_string();
    for (const std::string prefix : {kKeyframeTopicPrefix, kAgentStatsTopicPrefix})
      if (topic.size() > prefix.size() && topic.compare(0, prefix.size(), prefix) == 0) {
        const std::string robot = topic.substr(prefix.size());
        if (admission_->admit(robot) != RobotAdmission::Verdict::kAdmitted) return;
        std::lock_guard<std::mutex> lock(mutex_);
        if (announced_.insert(robot).second) fresh_.push_back(robot);
        wake_.set_trigger_value(true);
      }
  }

  // Robots announced since the last call.
  std::vector<std::string> take_new() {
    std::lock_guard<std::mutex> lock(mutex_);
    wake_.set_trigger_value(false);
    return std::exchange(fresh_, {});
  }

  fdds::GuardCondition& wake() { return wake_; }

 private:
  const std::string partition_;
  const std::shared_ptr<RobotAdmission> admission_;
  std::mutex mutex_;
  std::set<std::string> announced_;
  std::vector<std::string> fresh_;  // announced, not taken yet
  fdds::GuardCondition wake_;
};

// Which DDS sample brought each (robot, sequence number) the station took last, so that its
// acknowledgement names that sample (a robot takes only acknowledgements of its current writer's
// samples). Bounded: an acknowledgement follows its keyframe's take within a step, and one whose
// storage failed is never written, so the oldest entries go first.
class DeliveredSamples {
 public:
  void remember(const std::string& robot_id, std::uint64_t sequence, const SampleIdentity& id) {
    Key key{robot_id, sequence};
    Entry& entry = entries_[key];
    entry.sample = id;
    ++entry.takes;
    order_.push_back(std::move(key));
    if (order_.size() <= kCapacity) return;
    const auto oldest = entries_.find(order_.front());
    if (--oldest->second.takes == 0) entries_.erase(oldest);
    order_.pop_front();
  }

  std::optional<SampleIdentity> find(const std::string& robot_id, std::uint64_t sequence) const {
    const auto it = entries_.find(Key{robot_id, sequence});
    if (it == entries_.end()) return std::nullopt;
    return it->second.sample;
  }

 private:
  static constexpr std::size_t kCapacity = 4096;
  using Key = std::pair<std::string, std::uint64_t>;
  struct Entry {
    SampleIdentity sample;
    unsigned takes = 0;  // entries of `order_` naming this key
  };
  std::map<Key, Entry> entries_;
  std::deque<Key> order_;
};

class DdsStationLink final : public StationLink {
 public:
  DdsStationLink(const DdsSettings& settings, Logger logger,
                 std::shared_ptr<RobotAdmission> admission)
      : logger_(logger),
        discovery_(settings.partition, std::move(admission)),
        participant_(settings, "keyfleet_station", kStationIdentity, std::move(logger),
                     &discovery_),
        keyframe_type_(new dds::CheckedType<wire::KeyframePubSubType>()),
        stats_type_(new dds::CheckedType<wire::AgentStatsPubSubType>()),
        ack_type_(new dds::CheckedType<wire::KeyframeAckPubSubType>()) {
    ack_writer_ =
        participant_.writer(participant_.topic(kKeyframeAckTopic, ack_type_), Stream::kAcks);
    waitset_.attach_condition(discovery_.wake());
  }

  StationInbox take(std::chrono::milliseconds wait, std::size_t max_keyframes) override {
    subscribe_new_robots();
    wait_for_data(waitset_, readers_, wait);
    subscribe_new_robots();
    StationInbox inbox;
    fdds::SampleInfo info;
    for (auto& robot : robots_) {
      while (inbox.keyframes.size() < max_keyframes &&
             robot.keyframes->take_next_sample(&keyframe_sample_, &info) ==
                 ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        const std::uint64_t bytes = keyframe_type_->getSerializedSizeProvider(&keyframe_sample_)();
        delivered_.remember(keyframe_sample_.robot_id(), keyframe_sample_.sequence_number(),
                            info.sample_identity);
        inbox.keyframes.push_back(
            {dds::from_wire(std::move(keyframe_sample_)), bytes, robot.robot_id});
      }
      wire::AgentStats stats;
      while (robot.stats->take_next_sample(&stats, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        if (stats.robot_id() != robot.robot_id) {
          if (robot.warned_stats.insert(stats.robot_id()).second)
            logger_->error("ignored agent stats claiming robot id '{}' on robot '{}''s topic",
                           printable_text(stats.robot_id(), 64), printable_text(robot.robot_id));
          continue;
        }
        inbox.stats.push_back(dds::from_wire(stats));
      }
    }
    return inbox;
  }

  PublishResult acknowledge(const KeyframeAck& ack) override {
    dds::to_wire(ack, ack_sample_);
    PublishResult result;
    result.serialized_bytes = ack_type_->getSerializedSizeProvider(&ack_sample_)();
    WriteParams params;
    if (const auto sample = delivered_.find(ack.robot_id, ack.sequence_number))
      params.related_sample_identity(*sample);
    result.ok = ack_writer_->write(&ack_sample_, params);
    if (!result.ok) result.error = "DDS write failed on " + std::string(kKeyframeAckTopic);
    return result;
  }

  std::size_t matched_agents() const override {
    std::size_t matched = 0;
    for (const auto& robot : robots_) {
      fdds::SubscriptionMatchedStatus status;
      robot.keyframes->get_subscription_matched_status(status);
      matched += static_cast<std::size_t>(status.current_count);
    }
    return matched;
  }

 private:
  struct RobotReaders {
    std::string robot_id;
    fdds::DataReader* keyframes = nullptr;
    fdds::DataReader* stats = nullptr;
    std::set<std::string> warned_stats;
  };

  void subscribe_new_robots() {
    for (const auto& robot_id : discovery_.take_new()) {
      RobotReaders readers;
      readers.robot_id = robot_id;
      readers.keyframes = participant_.reader(
          participant_.topic(kKeyframeTopicPrefix + robot_id, keyframe_type_), Stream::kKeyframes);
      readers.stats = participant_.reader(
          participant_.topic(kAgentStatsTopicPrefix + robot_id, stats_type_), Stream::kStats);
      waitset_.attach_condition(readers.keyframes->get_statuscondition());
      waitset_.attach_condition(readers.stats->get_statuscondition());
      readers_.push_back(readers.keyframes);
      readers_.push_back(readers.stats);
      robots_.push_back(std::move(readers));
      logger_->debug("subscribed to robot '{}''s keyframes and stats",
                     printable_text(robot_id, 64));
    }
  }

  Logger logger_;
  RobotTopicDiscovery discovery_;
  Participant participant_;
  fdds::TypeSupport keyframe_type_;
  fdds::TypeSupport stats_type_;
  fdds::TypeSupport ack_type_;
  std::vector<RobotReaders> robots_;
  std::vector<fdds::DataReader*> readers_;
  fdds::DataWriter* ack_writer_ = nullptr;
  DeliveredSamples delivered_;
  fdds::WaitSet waitset_;
  wire::Keyframe keyframe_sample_;
  wire::KeyframeAck ack_sample_;
};

}  // namespace

std::unique_ptr<AgentLink> make_dds_agent_link(const DdsSettings& settings,
                                               const std::string& robot_id, Logger logger) {
  return std::make_unique<DdsAgentLink>(settings, robot_id, std::move(logger));
}

std::unique_ptr<StationLink> make_dds_station_link(const DdsSettings& settings, Logger logger,
                                                   std::shared_ptr<RobotAdmission> admission) {
  if (!admission) admission = std::make_shared<RobotAdmission>(StationLimits{}, logger);
  return std::make_unique<DdsStationLink>(settings, std::move(logger), std::move(admission));
}

}  // namespace keyfleet
