// AgentLink and StationLink over Fast DDS: the only place that moves bytes on the wire.
#include <fastdds/dds/core/condition/WaitSet.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "dds_participant.hpp"
#include "dds_wire_conversion.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleetPubSubTypes.h"

namespace keyfleet {
namespace {

using dds::Participant;
using dds::Stream;
namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::Duration_t;

Duration_t to_duration(std::chrono::milliseconds ms) {
  return Duration_t(static_cast<long double>(ms.count()) / 1000.0L);
}

// Waits until one of `readers` has unread data, or `wait` passes.
void wait_for_data(fdds::WaitSet& waitset, std::initializer_list<fdds::DataReader*> readers,
                   std::chrono::milliseconds wait) {
  for (auto* reader : readers)
    if (reader->get_unread_count() > 0) return;
  if (wait.count() <= 0) return;
  fdds::ConditionSeq active;
  waitset.wait(active, to_duration(wait));
}

class DdsAgentLink final : public AgentLink {
 public:
  DdsAgentLink(const DdsSettings& settings, Logger logger)
      : participant_(settings, "keyfleet_agent", std::move(logger)),
        keyframe_type_(new wire::KeyframePubSubType()),
        stats_type_(new wire::AgentStatsPubSubType()),
        ack_type_(new wire::KeyframeAckPubSubType()) {
    keyframe_writer_ =
        participant_.writer(participant_.topic(kKeyframeTopic, keyframe_type_), Stream::kKeyframes);
    stats_writer_ =
        participant_.writer(participant_.topic(kAgentStatsTopic, stats_type_), Stream::kStats);
    ack_reader_ =
        participant_.reader(participant_.topic(kKeyframeAckTopic, ack_type_), Stream::kAcks);
    waitset_.attach_condition(ack_reader_->get_statuscondition());
  }

  PublishResult publish(const Keyframe& keyframe) override {
    dds::to_wire(keyframe, keyframe_sample_);
    return write(keyframe_writer_, keyframe_type_, keyframe_sample_);
  }

  PublishResult publish(const AgentStats& stats) override {
    dds::to_wire(stats, stats_sample_);
    return write(stats_writer_, stats_type_, stats_sample_);
  }

  std::uint64_t serialized_size(const Keyframe& keyframe) const override {
    wire::Keyframe sample;
    dds::to_wire(keyframe, sample);
    auto type = keyframe_type_;
    return type->getSerializedSizeProvider(&sample)();
  }

  std::size_t matched_stations() const override {
    fdds::PublicationMatchedStatus status;
    keyframe_writer_->get_publication_matched_status(status);
    return static_cast<std::size_t>(status.current_count);
  }

  std::vector<KeyframeAck> take_acks(const std::string& robot_id,
                                     std::chrono::milliseconds wait) override {
    wait_for_data(waitset_, {ack_reader_}, wait);
    std::vector<KeyframeAck> acks;
    wire::KeyframeAck sample;
    fdds::SampleInfo info;
    while (ack_reader_->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data && sample.robot_id() == robot_id) acks.push_back(dds::from_wire(sample));
    }
    return acks;
  }

  bool flush_stats(std::chrono::milliseconds timeout) override {
    return stats_writer_->wait_for_acknowledgments(to_duration(timeout)) ==
           ReturnCode_t::RETCODE_OK;
  }

 private:
  template <class Wire>
  PublishResult write(fdds::DataWriter* writer, fdds::TypeSupport& type, Wire& sample) {
    PublishResult result;
    result.serialized_bytes = type->getSerializedSizeProvider(&sample)();
    result.ok = writer->write(&sample);
    if (!result.ok) result.error = "DDS write failed on " + writer->get_topic()->get_name();
    return result;
  }

  Participant participant_;
  fdds::TypeSupport keyframe_type_;
  fdds::TypeSupport stats_type_;
  fdds::TypeSupport ack_type_;
  fdds::DataWriter* keyframe_writer_ = nullptr;
  fdds::DataWriter* stats_writer_ = nullptr;
  fdds::DataReader* ack_reader_ = nullptr;
  fdds::WaitSet waitset_;
  wire::Keyframe keyframe_sample_;
  wire::AgentStats stats_sample_;
};

class DdsStationLink final : public StationLink {
 public:
  DdsStationLink(const DdsSettings& settings, Logger logger)
      : participant_(settings, "keyfleet_station", std::move(logger)),
        keyframe_type_(new wire::KeyframePubSubType()),
        stats_type_(new wire::AgentStatsPubSubType()),
        ack_type_(new wire::KeyframeAckPubSubType()) {
    keyframe_reader_ =
        participant_.reader(participant_.topic(kKeyframeTopic, keyframe_type_), Stream::kKeyframes);
    stats_reader_ =
        participant_.reader(participant_.topic(kAgentStatsTopic, stats_type_), Stream::kStats);
    ack_writer_ =
        participant_.writer(participant_.topic(kKeyframeAckTopic, ack_type_), Stream::kAcks);
    waitset_.attach_condition(keyframe_reader_->get_statuscondition());
    waitset_.attach_condition(stats_reader_->get_statuscondition());
  }

  StationInbox take(std::chrono::milliseconds wait, std::size_t max_keyframes) override {
    wait_for_data(waitset_, {keyframe_reader_, stats_reader_}, wait);
    StationInbox inbox;
    fdds::SampleInfo info;
    while (inbox.keyframes.size() < max_keyframes &&
           keyframe_reader_->take_next_sample(&keyframe_sample_, &info) ==
               ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      const std::uint64_t bytes = keyframe_type_->getSerializedSizeProvider(&keyframe_sample_)();
      inbox.keyframes.push_back({dds::from_wire(std::move(keyframe_sample_)), bytes});
    }
    wire::AgentStats stats;
    while (stats_reader_->take_next_sample(&stats, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) inbox.stats.push_back(dds::from_wire(stats));
    }
    return inbox;
  }

  PublishResult acknowledge(const KeyframeAck& ack) override {
    dds::to_wire(ack, ack_sample_);
    PublishResult result;
    result.serialized_bytes = ack_type_->getSerializedSizeProvider(&ack_sample_)();
    result.ok = ack_writer_->write(&ack_sample_);
    if (!result.ok) result.error = "DDS write failed on " + std::string(kKeyframeAckTopic);
    return result;
  }

  std::size_t matched_agents() const override {
    fdds::SubscriptionMatchedStatus status;
    keyframe_reader_->get_subscription_matched_status(status);
    return static_cast<std::size_t>(status.current_count);
  }

 private:
  Participant participant_;
  fdds::TypeSupport keyframe_type_;
  fdds::TypeSupport stats_type_;
  fdds::TypeSupport ack_type_;
  fdds::DataReader* keyframe_reader_ = nullptr;
  fdds::DataReader* stats_reader_ = nullptr;
  fdds::DataWriter* ack_writer_ = nullptr;
  fdds::WaitSet waitset_;
  wire::Keyframe keyframe_sample_;
  wire::KeyframeAck ack_sample_;
};

}  // namespace

std::unique_ptr<AgentLink> make_dds_agent_link(const DdsSettings& settings, Logger logger) {
  return std::make_unique<DdsAgentLink>(settings, std::move(logger));
}

std::unique_ptr<StationLink> make_dds_station_link(const DdsSettings& settings, Logger logger) {
  return std::make_unique<DdsStationLink>(settings, std::move(logger));
}

}  // namespace keyfleet
