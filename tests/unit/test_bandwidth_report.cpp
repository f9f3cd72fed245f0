// Bandwidth report: per-robot rows, fleet sums, saving ratios, CSV and JSON output.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "keyfleet/station/bandwidth_report.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

constexpr std::int64_t kMinute = 60'000'000'000LL;

RobotTotals robot(const std::string& id, std::uint64_t keyframes, std::uint64_t received,
                  std::uint64_t stream_all, std::uint64_t vslam, bool finished = true) {
  RobotTotals t;
  t.robot_id = id;
  t.keyframes = keyframes;
  t.serialized_bytes = received;
  t.image_bytes = received - keyframes;
  t.first_received_ns = 0;
  t.last_received_ns = 2 * kMinute;
  AgentStats s;
  s.robot_id = id;
  s.finished = finished;
  s.frames_seen = keyframes * 15;
  s.vslam_keyframes = keyframes * 2;
  s.keyframes_sent = keyframes + 1;
  s.keyframes_resent = 2;
  s.keyframes_dropped = 1;
  s.keyframes_pending = 0;
  s.bytes_sent = received + 50;
  s.bytes_resent = 30;
  s.stream_all_bytes = stream_all;
  s.stream_all_estimated = true;
  s.vslam_keyframe_bytes = vslam;
  s.vslam_keyframe_estimated = false;
  t.latest_stats = s;
  return t;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> fields_of(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
  return fields;
}

TEST(BandwidthRow, SavingIsBaselineOverReceived) {
  BandwidthRow row;
  row.bytes_received = 100;
  row.bytes_received_with_baseline = 100;
  row.stream_all_bytes = 1000;
  row.vslam_keyframe_bytes = 250;
  EXPECT_DOUBLE_EQ(row.saving_vs_stream_all(), 10.0);
  EXPECT_DOUBLE_EQ(row.saving_vs_vslam(), 2.5);
}

TEST(BandwidthRow, SavingIsZeroWhenNothingWasReceived) {
  BandwidthRow row;
  row.stream_all_bytes = 1000;
  EXPECT_EQ(row.saving_vs_stream_all(), 0.0);
  EXPECT_EQ(row.saving_vs_vslam(), 0.0);
}

TEST(BuildBandwidthReport, CopiesPerRobotFiguresFromTotalsAndStats) {
  const auto report = build_bandwidth_report({robot("alpha", 10, 100, 1000, 400)});
  ASSERT_EQ(report.robots.size(), 1u);
  const BandwidthRow& a = report.robots[0];
  EXPECT_EQ(a.robot_id, "alpha");
  EXPECT_EQ(a.keyframes_stored, 10u);
  EXPECT_EQ(a.bytes_received, 100u);
  EXPECT_TRUE(a.has_agent_stats);
  EXPECT_TRUE(a.agent_finished);
  EXPECT_EQ(a.frames_seen, 150u);
  EXPECT_EQ(a.keyframes_resent, 2u);
  EXPECT_EQ(a.keyframes_dropped, 1u);
  EXPECT_EQ(a.bytes_sent_total, 100u + 50u + 30u);
  EXPECT_EQ(a.stream_all_bytes, 1000u);
  EXPECT_TRUE(a.stream_all_estimated);
  EXPECT_FALSE(a.vslam_keyframe_estimated);
  EXPECT_DOUBLE_EQ(a.saving_vs_stream_all(), 10.0);
  EXPECT_DOUBLE_EQ(a.saving_vs_vslam(), 4.0);
  EXPECT_DOUBLE_EQ(a.keyframes_per_minute, 5.0);  // 10 keyframes over 2 minutes
}

TEST(BuildBandwidthReport, FleetRowSumsRobotsAndGivesFleetSavings) {
  const auto report = build_bandwidth_report(
      {robot("alpha", 10, 100, 1000, 400), robot("bravo", 20, 300, 2000, 800)});
  ASSERT_EQ(report.robots.size(), 2u);
  const BandwidthRow& fleet = report.fleet;
  EXPECT_EQ(fleet.robot_id, "FLEET");
  EXPECT_EQ(fleet.keyframes_stored, 30u);
  EXPECT_EQ(fleet.bytes_received, 400u);
  EXPECT_EQ(fleet.frames_seen, 450u);
  EXPECT_EQ(fleet.keyframes_resent, 4u);
  EXPECT_EQ(fleet.keyframes_dropped, 2u);
  EXPECT_EQ(fleet.stream_all_bytes, 3000u);
  EXPECT_EQ(fleet.vslam_keyframe_bytes, 1200u);
  EXPECT_TRUE(fleet.stream_all_estimated);
  EXPECT_FALSE(fleet.vslam_keyframe_estimated);
  EXPECT_TRUE(fleet.agent_finished);
  EXPECT_DOUBLE_EQ(fleet.saving_vs_stream_all(), 7.5);
  EXPECT_DOUBLE_EQ(fleet.saving_vs_vslam(), 3.0);
  EXPECT_DOUBLE_EQ(fleet.keyframes_per_minute, 15.0);
}

TEST(BuildBandwidthReport, FleetIsUnfinishedWhenAnyRobotIsUnfinished) {
  const auto report = build_bandwidth_report(
      {robot("alpha", 10, 100, 1000, 400), robot("bravo", 20, 300, 2000, 800, false)});
  EXPECT_FALSE(report.fleet.agent_finished);
}

TEST(BuildBandwidthReport, RobotWithoutStatsHasNoBaselines) {
  RobotTotals quiet;
  quiet.robot_id = "quiet";
  quiet.keyframes = 3;
  quiet.serialized_bytes = 90;
  quiet.rejected = 2;
  const auto report = build_bandwidth_report({quiet});
  ASSERT_EQ(report.robots.size(), 1u);
  const BandwidthRow& row = report.robots[0];
  EXPECT_FALSE(row.has_agent_stats);
  EXPECT_FALSE(row.agent_finished);
  EXPECT_EQ(row.rejected, 2u);
  EXPECT_EQ(row.stream_all_bytes, 0u);
  EXPECT_EQ(row.saving_vs_stream_all(), 0.0);
  EXPECT_EQ(row.keyframes_per_minute, 0.0);  // no time span
  EXPECT_FALSE(report.fleet.has_agent_stats);
  EXPECT_EQ(report.fleet.rejected, 2u);
}

TEST(BuildBandwidthReport, FleetSavingIgnoresBytesOfRobotsWithoutBaselines) {
  RobotTotals quiet;
  quiet.robot_id = "quiet";
  quiet.keyframes = 3;
  quiet.serialized_bytes = 900;
  const auto report = build_bandwidth_report({robot("alpha", 10, 100, 1000, 400), quiet});
  EXPECT_EQ(report.fleet.bytes_received, 1000u);
  EXPECT_EQ(report.fleet.bytes_received_with_baseline, 100u);
  EXPECT_DOUBLE_EQ(report.fleet.saving_vs_stream_all(), 10.0);
}

TEST(BuildBandwidthReport, NoRobotsGivesAnEmptyFleetRow) {
  const auto report = build_bandwidth_report({});
  EXPECT_TRUE(report.robots.empty());
  EXPECT_EQ(report.fleet.robot_id, "FLEET");
  EXPECT_EQ(report.fleet.bytes_received, 0u);
  EXPECT_EQ(report.fleet.saving_vs_stream_all(), 0.0);
}

// A robot that adapted to its link says what it gave up, in the table, the JSON and the CSV; a
// robot that did not adds no line.
TEST(BandwidthReportAdaptation, RobotsThatAdaptedSayWhatTheyGaveUp) {
  auto adapted = robot("drone_0", 10, 200'000, 9'000'000, 900'000);
  adapted.latest_stats->keyframes_reduced = 7;
  adapted.latest_stats->keyframes_thinned = 2;
  adapted.latest_stats->level_changes = 3;
  adapted.latest_stats->send_quality = 40;
  adapted.latest_stats->send_scale = 0.5;
  adapted.latest_stats->send_density = 2;
  adapted.latest_stats->link_bytes_per_s = 21'300;
  adapted.latest_stats->link_rtt_ms = 850;
  const auto steady = robot("drone_1", 10, 500'000, 9'000'000, 900'000);
  const BandwidthReport report = build_bandwidth_report({adapted, steady});
  const std::string table = format_table(report);
  EXPECT_NE(table.find("link adaptation drone_0: 7 of 11 keyframes sent reduced, 2 held back, 3 "
                       "level changes; now JPEG q40 at 0.5 of the frame, one in 2; link 21.3 "
                       "kB/s, round trip 850 ms"),
            std::string::npos)
      << table;
  EXPECT_EQ(table.find("link adaptation drone_1"), std::string::npos);
  const auto json = nlohmann::json::parse(to_json(report));
  EXPECT_EQ(json["robots"][0]["keyframes_reduced"], 7);
  EXPECT_EQ(json["robots"][0]["send_scale"], 0.5);
  EXPECT_EQ(json["fleet"]["level_changes"], 3);
  const auto csv = lines_of(to_csv(report));
  const auto header = fields_of(csv[0]);
  const auto row = fields_of(csv[1]);
  ASSERT_EQ(header.size(), row.size());
  const auto column = std::find(header.begin(), header.end(), "keyframes_reduced") - header.begin();
  EXPECT_EQ(row[static_cast<std::size_t>(column)], "7");
}

TEST(BandwidthReportSecurity, ARunWithoutDdsSecuritySaysSoInTheTableAndTheJson) {
  BandwidthReport report = build_bandwidth_report({});
  EXPECT_EQ(format_table(report).find("DDS-Security: off"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(to_json(report))["dds_security"], true);
  report.dds_security = false;
  EXPECT_NE(format_table(report).find("DDS-Security: off"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(to_json(report))["dds_security"], false);
}

TEST(BandwidthReportSecurity, RobotsWithoutIdentityAndWithdrawnOnesAreCounted) {
  BandwidthReport report = build_bandwidth_report({});
  report.refused.no_identity = 2;
  report.refused.withdrawn = 1;
  report.refused.ids = {"stranger", "ghost", "lost"};
  const auto json = nlohmann::json::parse(to_json(report));
  EXPECT_EQ(json["refused_robots"]["no_identity"], 2);
  EXPECT_EQ(json["refused_robots"]["withdrawn"], 1);
  EXPECT_NE(format_table(report).find("2 without an identity, 1 withdrawn"), std::string::npos)
      << format_table(report);
}

TEST(BandwidthReportCsv, HasHeaderOneLinePerRobotAndFleetLast) {
  const auto report = build_bandwidth_report(
      {robot("alpha", 10, 100, 1000, 400), robot("bravo", 20, 300, 2000, 800)});
  const auto lines = lines_of(to_csv(report));
  ASSERT_EQ(lines.size(), 4u);
  const auto header = fields_of(lines[0]);
  ASSERT_FALSE(header.empty());
  EXPECT_EQ(header[0], "robot_id");
  EXPECT_EQ(fields_of(lines[1])[0], "alpha");
  EXPECT_EQ(fields_of(lines[2])[0], "bravo");
  EXPECT_EQ(fields_of(lines[3])[0], "FLEET");
  for (std::size_t i = 1; i < lines.size(); ++i)
    EXPECT_EQ(fields_of(lines[i]).size(), header.size()) << lines[i];
}

TEST(BandwidthReportCsv, ValuesLineUpWithTheirColumns) {
  const auto report = build_bandwidth_report({robot("alpha", 10, 100, 1000, 400)});
  const auto lines = lines_of(to_csv(report));
  ASSERT_GE(lines.size(), 2u);
  const auto header = fields_of(lines[0]);
  const auto alpha = fields_of(lines[1]);
  ASSERT_EQ(alpha.size(), header.size());
  auto column = [&](const std::string& name) -> std::string {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return alpha[i];
    ADD_FAILURE() << "no column " << name;
    return {};
  };
  EXPECT_EQ(column("keyframes_stored"), "10");
  EXPECT_EQ(column("bytes_received"), "100");
  EXPECT_EQ(column("stream_all_bytes"), "1000");
  EXPECT_DOUBLE_EQ(std::stod(column("saving_vs_stream_all")), 10.0);
  EXPECT_DOUBLE_EQ(std::stod(column("saving_vs_vslam")), 4.0);
}

TEST(BandwidthReportJson, ParsesWithRobotsAndFleet) {
  const auto report = build_bandwidth_report(
      {robot("alpha", 10, 100, 1000, 400), robot("bravo", 20, 300, 2000, 800)});
  const auto doc = nlohmann::json::parse(to_json(report));
  ASSERT_TRUE(doc.contains("robots"));
  ASSERT_EQ(doc["robots"].size(), 2u);
  EXPECT_EQ(doc["robots"][0]["robot_id"], "alpha");
  EXPECT_EQ(doc["robots"][0]["bytes_received"], 100);
  EXPECT_DOUBLE_EQ(doc["robots"][0]["saving_vs_stream_all"].get<double>(), 10.0);
  EXPECT_EQ(doc["robots"][1]["robot_id"], "bravo");
  EXPECT_EQ(doc["fleet"]["robot_id"], "FLEET");
  EXPECT_EQ(doc["fleet"]["bytes_received"], 400);
  EXPECT_EQ(doc["fleet"]["stream_all_bytes"], 3000);
  EXPECT_EQ(doc["fleet"]["stream_all_estimated"], true);
  EXPECT_DOUBLE_EQ(doc["fleet"]["saving_vs_stream_all"].get<double>(), 7.5);
}

TEST(BandwidthReportTable, ShowsEveryRobotFleetAndNaWithoutStats) {
  RobotTotals quiet;
  quiet.robot_id = "quiet";
  quiet.keyframes = 1;
  quiet.serialized_bytes = 10;
  const auto table =
      format_table(build_bandwidth_report({robot("alpha", 10, 100, 1000, 400), quiet}));
  EXPECT_NE(table.find("alpha"), std::string::npos) << table;
  EXPECT_NE(table.find("quiet"), std::string::npos) << table;
  EXPECT_NE(table.find("FLEET"), std::string::npos) << table;
  EXPECT_NE(table.find("10.0x"), std::string::npos) << table;
  EXPECT_NE(table.find("n/a"), std::string::npos) << table;
}

TEST(WriteBandwidthReport, WritesJsonCsvAndTableFiles) {
  keyfleet::test::TempDir dir;
  const auto report = build_bandwidth_report({robot("alpha", 10, 100, 1000, 400)});
  const std::string table = write_bandwidth_report(report, dir.path().string());
  EXPECT_EQ(table, format_table(report));

  std::ifstream json_in(dir.file("report.json"));
  ASSERT_TRUE(json_in.good());
  const auto doc = nlohmann::json::parse(json_in);
  EXPECT_EQ(doc["fleet"]["keyframes_stored"], 10);

  std::ifstream csv_in(dir.file("report.csv"));
  std::stringstream csv;
  csv << csv_in.rdbuf();
  EXPECT_EQ(csv.str(), to_csv(report));

  std::ifstream txt_in(dir.file("report.txt"));
  std::stringstream txt;
  txt << txt_in.rdbuf();
  EXPECT_EQ(txt.str(), table);
}

}  // namespace
}  // namespace keyfleet::station

namespace keyfleet::station {
namespace {

TEST(BandwidthTimeline, ReceivedAccumulatesInReceiveOrderAndBaselinesFollowTheStats) {
  std::vector<StoredKeyframeInfo> keyframes(3);
  keyframes[0] = {"drone_1", 1, 0, std::nullopt, 5, 300, 1000, 64, 48};
  keyframes[1] = {"drone_0", 2, 0, std::nullopt, 9, 200, 500, 64, 48};
  keyframes[2] = {"drone_0", 1, 0, std::nullopt, 4, 100, 700, 64, 48};
  const std::vector<StatsSample> stats = {{"drone_0", 150, 10, 5000, 1500},
                                          {"drone_0", 250, 20, 9000, 2500},
                                          {"drone_2", 260, 5, 100, 10}};
  const auto series = build_bandwidth_timeline(keyframes, stats);
  ASSERT_EQ(series.size(), 3u);
  EXPECT_EQ(series[0].robot_id, "drone_0");
  ASSERT_EQ(series[0].received.size(), 2u);
  EXPECT_EQ(series[0].received[0].time_ns, 100);
  EXPECT_EQ(series[0].received[0].bytes, 700u);
  EXPECT_EQ(series[0].received[1].bytes, 1200u);
  ASSERT_EQ(series[0].stream_all.size(), 2u);
  EXPECT_EQ(series[0].stream_all[1].bytes, 9000u);
  EXPECT_EQ(series[0].vslam_keyframes[0].bytes, 1500u);
  EXPECT_EQ(series[1].received[0].bytes, 1000u);
  EXPECT_TRUE(series[1].stream_all.empty());
  EXPECT_TRUE(series[2].received.empty());  // stats but no keyframe yet
}

}  // namespace
}  // namespace keyfleet::station
