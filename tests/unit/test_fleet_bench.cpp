// The fleet benchmark's arithmetic on hand-made timings: real-time factors, late frames, CPU
// per frame per stage, frames per second per core, and the largest fleet at real time.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "keyfleet/agent/agent_runner.hpp"
#include "keyfleet/mission/fleet_bench.hpp"
#include "test_support.hpp"

namespace keyfleet::mission {
namespace {

AgentStreamFigures agent(double stream_s, std::uint64_t late, double trigger_ms) {
  AgentStreamFigures a;
  a.frames = 300;  // 10 s at 30 fps
  a.fps = 30;
  a.stream_s = stream_s;
  a.late_frames = late;
  a.max_lag_ms = double(late) * 10;
  a.process_cpu_s = 3.0;  // 10 ms a frame
  a.stream_cpu_s = 2.4;   // 8 ms a frame while streaming
  a.stages["trigger"] = {"trigger", trigger_ms * 300, 300};
  return a;
}

TEST(FleetFigures, RealTimeFactorsCpuAndStagesFromHandMadeTimings) {
  StationFigures station;
  station.cpu_s = 1.2;
  station.start_cpu_s = 0.3;  // its models and DDS, before the first keyframe
  station.keyframes = 4;
  station.text_ms = 800;
  station.text_cpu_ms = 600;
  station.places_ms = 40;
  const auto r =
      fleet_figures(2, true, {agent(10.0, 0, 1.0), agent(12.5, 30, 3.0)}, station, 13.0, 2, 0.98);
  EXPECT_DOUBLE_EQ(r.rtf_min, 0.8);  // 10 s of flight in 12.5 s
  EXPECT_DOUBLE_EQ(r.rtf_mean, 0.9);
  EXPECT_EQ(r.frames, 600u);
  EXPECT_EQ(r.late_frames, 30u);
  EXPECT_DOUBLE_EQ(r.max_lag_ms, 300);
  EXPECT_DOUBLE_EQ(r.agent_cpu_ms_per_frame, 10.0);
  EXPECT_DOUBLE_EQ(r.agent_stream_cpu_ms_per_frame, 8.0);
  EXPECT_DOUBLE_EQ(r.stage_ms_per_frame.at("trigger"), 2.0);
  EXPECT_DOUBLE_EQ(r.station_cpu_ms_per_frame, 2.0);
  EXPECT_DOUBLE_EQ(r.station_work_cpu_ms_per_frame, 1.5);
  EXPECT_DOUBLE_EQ(r.station_text_ms_per_keyframe, 200);
  EXPECT_DOUBLE_EQ(r.station_text_cpu_ms_per_keyframe, 150);
  EXPECT_DOUBLE_EQ(r.station_places_ms_per_keyframe, 10);
  EXPECT_NEAR(r.frames_per_s_per_core, 600.0 / 13.0 / 2.0, 1e-12);
  EXPECT_FALSE(r.keeps_realtime);
  EXPECT_TRUE(fleet_figures(1, true, {agent(10.1, 0, 1.0)}, station, 10.2, 2, 0.98).keeps_realtime);
  EXPECT_FALSE(fleet_figures(1, false, {agent(5.0, 0, 1.0)}, station, 5.1, 2, 0.98).keeps_realtime)
      << "an as-fast-as-possible run says nothing about real time";
}

TEST(FleetFigures, LargestRealTimeFleetStopsAtTheFirstThatFallsBehind) {
  StationFigures station;
  std::vector<FleetRunFigures> runs;
  for (const auto& [n, stream_s] :
       std::vector<std::pair<int, double>>{{4, 10.0}, {1, 10.0}, {2, 10.05}, {6, 11.0}, {8, 10.0}})
    runs.push_back(fleet_figures(n, true, {agent(stream_s, 0, 1.0)}, station, 10, 2, 0.98));
  runs.push_back(fleet_figures(10, false, {agent(3, 0, 1.0)}, station, 3, 2, 0.98));
  EXPECT_EQ(largest_realtime(runs), 4) << "6 fell behind; 8 on time is not counted past it";
  runs[1].failures.push_back("drone_0 exited with code 1");
  EXPECT_EQ(largest_realtime(runs), std::nullopt) << "a failed run keeps nothing";
  const std::string table = format_fleet_table(runs, 2);
  EXPECT_NE(table.find("largest N at real time: none"), std::string::npos) << table;
  EXPECT_NE(table.find("trigger"), std::string::npos) << table;
  EXPECT_NE(table.find("strm ms/f"), std::string::npos) << table;
  EXPECT_NE(table.find("stn work"), std::string::npos) << table;
  EXPECT_NE(table.find("read p95+dfr"), std::string::npos) << table;
}

TEST(FleetFigures, TheStationsReadLagAndDeferralsAreCarriedAndShownOnlyWhereWritten) {
  StationFigures station;
  station.read_lag_p95_s = 2.46;  // from its process.json
  station.read_lag_max_s = 7.5;
  const auto r = fleet_figures(1, true, {agent(10.0, 0, 1.0)}, station, 10.0, 2, 0.98);
  EXPECT_DOUBLE_EQ(r.station_read_lag_p95_s, 2.46);
  EXPECT_DOUBLE_EQ(r.station_read_lag_max_s, 7.5);
  const std::string with = format_fleet_table({r}, 2);
  EXPECT_NE(with.find(" 2.5 "), std::string::npos) << with;
  station.deferred = 130;  // a full queue put these off until after the flight
  const auto behind = fleet_figures(1, true, {agent(10.0, 0, 1.0)}, station, 10.0, 2, 0.98);
  EXPECT_EQ(behind.station_deferred, 130);
  const std::string shown = format_fleet_table({behind}, 2);
  EXPECT_NE(shown.find(" 2.5+130 "), std::string::npos) << shown;
  const auto older = fleet_figures(1, true, {agent(10.0, 0, 1.0)}, StationFigures{}, 10.0, 2, 0.98);
  EXPECT_LT(older.station_read_lag_p95_s, 0) << "a station that wrote no latency";
  const std::string without = format_fleet_table({older}, 2);
  EXPECT_EQ(without.find(" 2.5 "), std::string::npos) << without;
  EXPECT_NE(without.find(" - "), std::string::npos) << without;
}

TEST(FleetFigures, EveryFigureGoesToJsonAndWhatTheStationDidNotWriteIsNull) {
  StationFigures station;
  station.read_lag_p95_s = 2.46;
  station.read_lag_max_s = 7.5;
  station.deferred = 3;
  std::vector<FleetRunFigures> runs = {
      fleet_figures(2, true, {agent(10.0, 0, 1.0), agent(10.0, 4, 1.0)}, station, 10.0, 2, 0.98),
      fleet_figures(4, true, {agent(12.0, 0, 1.0)}, StationFigures{}, 12.0, 2, 0.98)};
  const nlohmann::json j = fleet_json(runs, 2, "CPU: test");
  EXPECT_EQ(j.at("cores"), 2);
  EXPECT_EQ(j.at("cpu"), "CPU: test");
  EXPECT_EQ(j.at("largest_realtime"), 2) << "4 fell behind";
  ASSERT_EQ(j.at("runs").size(), 2u);
  const auto& first = j.at("runs")[0];
  EXPECT_EQ(first.at("drones"), 2);
  EXPECT_EQ(first.at("late_frames"), runs[0].late_frames);
  EXPECT_DOUBLE_EQ(first.at("station_read_lag_p95_s").get<double>(), 2.46);
  EXPECT_DOUBLE_EQ(first.at("station_read_lag_max_s").get<double>(), 7.5);
  EXPECT_EQ(first.at("station_deferred"), 3);
  EXPECT_EQ(first.at("stage_ms_per_frame").size(), runs[0].stage_ms_per_frame.size());
  EXPECT_DOUBLE_EQ(first.at("agent_cpu_ms_per_frame").get<double>(),
                   runs[0].agent_cpu_ms_per_frame);
  const auto& second = j.at("runs")[1];
  EXPECT_TRUE(second.at("station_read_lag_max_s").is_null());
  EXPECT_TRUE(second.at("station_deferred").is_null());
  EXPECT_FALSE(second.at("keeps_realtime").get<bool>());
  runs[1].failures.push_back("drone_3 exited with code 1");
  EXPECT_EQ(fleet_json(runs, 2, "").at("runs")[1].at("failures")[0], "drone_3 exited with code 1");
}

TEST(StreamSummary, ReadsWhatTheAgentWritesAndNamesABrokenFile) {
  test::TempDir dir;
  const std::string path = dir.file("stream.json");
  agent::StreamSummary summary;
  summary.frames = 600;
  summary.fps = 30;
  summary.stream_s = 20.5;
  summary.late_frames = 3;
  summary.max_lag_ms = 45.5;
  summary.stream_cpu_s = 6.5;
  ASSERT_TRUE(agent::write_stream_summary(path, summary, {{"trigger", 900, 600}}, 7.25));
  const auto f = read_stream_summary(path, "drone_3");
  EXPECT_EQ(f.robot_id, "drone_3");
  EXPECT_EQ(f.frames, 600u);
  EXPECT_DOUBLE_EQ(f.stream_s, 20.5);
  EXPECT_EQ(f.late_frames, 3u);
  EXPECT_DOUBLE_EQ(f.process_cpu_s, 7.25);
  EXPECT_DOUBLE_EQ(f.stream_cpu_s, 6.5);
  EXPECT_DOUBLE_EQ(f.stages.at("trigger").cpu_ms_total, 900);
  EXPECT_EQ(f.stages.at("trigger").calls, 600u);
  std::ofstream(path) << "{\"frames\": 1}";
  try {
    read_stream_summary(path, "drone_3");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace keyfleet::mission
