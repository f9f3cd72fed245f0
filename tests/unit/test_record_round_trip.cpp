// Every field of a keyframe and of an agent-stats sample, each set to a value of its own, through
// every copy the code makes of them: the DDS wire types, the outbox, the station's tables, the
// mission log's protobuf record, JSON and CSV. A copy that drops a field fails naming it; the
// fields a copy leaves out by design are named here.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "dds_wire_conversion.hpp"
#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/common/record_export.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/record_proto.hpp"
#include "mission_log.pb.h"
#include "record_test_support.hpp"
#include "test_support.hpp"

namespace keyfleet {
namespace {

using test::dropped_fields;
using test::every_field_set;
using Fields = std::vector<std::string>;

// The exports and the mission log keep the image's size (and the log its hash), not its bytes.
const std::set<std::string> kImageLeftOut = {"image"};
const std::set<std::string> kNotLogged = {"image", "camera_pose", "text_regions"};

template <class R>
std::size_t field_count() {
  test::FieldTexts texts;
  const R record{};
  visit_fields(texts, record);
  return texts.texts.size();
}

TEST(RecordRoundTrip, FillingSetsEveryFieldToANonDefaultValue) {
  EXPECT_EQ(dropped_fields(Keyframe{}, every_field_set<Keyframe>()).size(),
            field_count<Keyframe>());
  EXPECT_EQ(dropped_fields(AgentStats{}, every_field_set<AgentStats>()).size(),
            field_count<AgentStats>());
}

TEST(RecordRoundTrip, WireKeepsEveryField) {
  const auto k = every_field_set<Keyframe>();
  wire::Keyframe wk;
  dds::to_wire(k, wk);
  EXPECT_EQ(dropped_fields(k, dds::from_wire(std::move(wk))), Fields{});
  const auto s = every_field_set<AgentStats>();
  wire::AgentStats ws;
  dds::to_wire(s, ws);
  EXPECT_EQ(dropped_fields(s, dds::from_wire(ws)), Fields{});
}

TEST(RecordRoundTrip, OutboxKeepsEveryField) {
  test::TempDir dir;
  auto k = every_field_set<Keyframe>();
  agent::Outbox outbox(dir.file("outbox.sqlite"), k.robot_id, OutboxConfig{});
  k.sequence_number = outbox.next_sequence();  // the outbox numbers keyframes from 0
  outbox.add(k, 1);
  const auto due = outbox.due_for_resend(2, 10);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(dropped_fields(k, due[0]), Fields{});
}

TEST(RecordRoundTrip, StationTablesKeepEveryField) {
  test::TempDir dir;
  station::KeyframeStore store(dir.file("station.sqlite"));
  const auto k = every_field_set<Keyframe>();
  ASSERT_EQ(store.store(k, 99, 5), station::StoreOutcome::kStored);
  const auto loaded = store.load(k.robot_id, k.sequence_number);
  ASSERT_TRUE(loaded);
  EXPECT_EQ(dropped_fields(k, *loaded), Fields{});
  const auto s = every_field_set<AgentStats>();
  store.record_stats(s);
  const auto totals = store.totals();
  ASSERT_EQ(totals.size(), 1u);  // both filled samples are robot "text_1"'s
  ASSERT_TRUE(totals[0].latest_stats);
  EXPECT_EQ(dropped_fields(s, *totals[0].latest_stats), Fields{});
}

TEST(RecordRoundTrip, MissionLogRecordKeepsEveryFieldButTheImageThePoseAndTheRegions) {
  const auto k = every_field_set<Keyframe>();
  records::KeyframeRecord kr;
  station::to_proto(k, kr);
  Keyframe k2;
  station::from_proto(kr, k2);
  EXPECT_EQ(dropped_fields(k, k2, kNotLogged), Fields{});
  const auto s = every_field_set<AgentStats>();
  records::AgentStatsRecord sr;
  station::to_proto(s, sr);
  AgentStats s2;
  station::from_proto(sr, s2);
  EXPECT_EQ(dropped_fields(s, s2), Fields{});
  EXPECT_EQ(station::fields_missing_from(kr, Keyframe{}), Fields{});
  EXPECT_EQ(station::fields_missing_from(sr, AgentStats{}), Fields{});
}

TEST(RecordRoundTrip, JsonKeepsEveryFieldButTheImageBytes) {
  const auto k = every_field_set<Keyframe>();
  Keyframe k2;
  from_json(to_json(k), k2);
  EXPECT_EQ(dropped_fields(k, k2, kImageLeftOut), Fields{});
  const auto s = every_field_set<AgentStats>();
  AgentStats s2;
  from_json(to_json(s), s2);
  EXPECT_EQ(dropped_fields(s, s2), Fields{});
}

TEST(RecordRoundTrip, CsvKeepsEveryFieldButTheImageBytes) {
  auto k = every_field_set<Keyframe>();
  k.robot_id = "drone, \"quoted\"";  // a cell that needs quoting
  Keyframe k2;
  from_csv_row(csv_row(k), k2);
  EXPECT_EQ(dropped_fields(k, k2, kImageLeftOut), Fields{});
  Keyframe without_pose = k;
  without_pose.camera_pose.reset();
  Keyframe k3;
  from_csv_row(csv_row(without_pose), k3);
  EXPECT_FALSE(k3.camera_pose);
  const auto s = every_field_set<AgentStats>();
  AgentStats s2;
  from_csv_row(csv_row(s), s2);
  EXPECT_EQ(dropped_fields(s, s2), Fields{});
  EXPECT_EQ(csv_header<AgentStats>().rfind("robot_id,report_time_ns,finished,", 0), 0u);
}

}  // namespace
}  // namespace keyfleet
