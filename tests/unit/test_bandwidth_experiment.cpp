// The bandwidth experiment's arithmetic on hand-made cases with known answers.
#include <gtest/gtest.h>

#include <unistd.h>

#include <ctime>
#include <filesystem>
#include <fstream>

#include "keyfleet/common/config.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/error.hpp"
#include "keyfleet/mission/bandwidth_experiment.hpp"
#include "keyfleet/mission/bandwidth_metrics.hpp"
#include "keyfleet/mission/experiment_config.hpp"

namespace keyfleet::mission {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;

DeliveredKeyframe kf(const std::string& robot, double capture_s, double received_s,
                     std::uint64_t bytes) {
  return {robot, static_cast<std::int64_t>(capture_s * kSecond),
          static_cast<std::int64_t>(received_s * kSecond), bytes};
}

TEST(Percentiles, MedianOfOddAndEvenCounts) {
  EXPECT_DOUBLE_EQ(median({5, 1, 3}), 3);
  EXPECT_DOUBLE_EQ(median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(median({7}), 7);
  EXPECT_DOUBLE_EQ(median({}), 0);
}

TEST(Percentiles, LinearBetweenClosestRanks) {
  // 1..21: rank 0.95 * 20 = 19 -> the 20th value exactly.
  std::vector<double> values;
  for (int i = 21; i >= 1; --i) values.push_back(i);
  EXPECT_DOUBLE_EQ(percentile(values, 95), 20);
  // 0, 10: p95 lies 95 % of the way.
  EXPECT_DOUBLE_EQ(percentile({10, 0}, 95), 9.5);
  EXPECT_DOUBLE_EQ(percentile({10, 0}, 0), 0);
  EXPECT_DOUBLE_EQ(percentile({10, 0}, 100), 10);
}

TEST(Binning, BytesFallInTheSecondTheyArrived) {
  const std::vector<DeliveredKeyframe> ks = {kf("a", 0, 10.0, 100), kf("a", 0, 10.999, 50),
                                             kf("a", 0, 11.0, 7), kf("a", 0, 13.5, 1000),
                                             kf("a", 0, 9.0, 3)};  // before the origin: bin 0
  const auto bins = bytes_per_bin(ks, 10 * kSecond, kSecond);
  ASSERT_EQ(bins.size(), 4u);
  EXPECT_EQ(bins[0], 153u);
  EXPECT_EQ(bins[1], 7u);
  EXPECT_EQ(bins[2], 0u);
  EXPECT_EQ(bins[3], 1000u);
  EXPECT_TRUE(bytes_per_bin({}, 0, kSecond).empty());
  EXPECT_TRUE(bytes_per_bin(ks, 0, 0).empty());
}

TEST(Throughput, BytesAfterTheFirstOverTheSpan) {
  // The first sample's 999 bytes arrived before the span began.
  const std::vector<DeliveredKeyframe> ks = {kf("a", 0, 3.0, 500), kf("a", 0, 1.0, 999),
                                             kf("a", 0, 5.0, 1500)};
  EXPECT_DOUBLE_EQ(throughput_bytes_per_s(ks), 2000.0 / 4.0);
  EXPECT_DOUBLE_EQ(throughput_bytes_per_s({kf("a", 0, 1, 10)}), 0);
  EXPECT_DOUBLE_EQ(throughput_bytes_per_s({kf("a", 0, 1, 10), kf("a", 0, 1, 10)}), 0);
}

TEST(Savings, BaselineOverSent) {
  EXPECT_DOUBLE_EQ(saving_ratio(1000, 250), 4.0);
  EXPECT_DOUBLE_EQ(saving_ratio(1000, 0), 0);
  EXPECT_DOUBLE_EQ(saving_ratio(0, 10), 0);
}

TEST(RobotMetrics, SumsLatenciesAndSavingsOfOneRobot) {
  const std::vector<DeliveredKeyframe> ks = {kf("a", 1.0, 1.1, 100),
                                             kf("b", 0, 50, 1'000'000),  // another robot: ignored
                                             kf("a", 2.0, 2.3, 200), kf("a", 3.0, 3.2, 300)};
  AgentTotals totals;
  totals.keyframes_dropped = 2;
  totals.keyframes_resent = 5;
  totals.bytes_sent = 600;
  totals.bytes_resent = 400;
  totals.stream_all_bytes = 6000;
  totals.stream_all_estimated = true;
  totals.vslam_keyframe_bytes = 1200;
  totals.vslam_keyframe_estimated = false;
  const auto m = robot_metrics("a", ks, totals, WireBytes{1500, 80});
  EXPECT_EQ(m.delivered, 3u);
  EXPECT_EQ(m.payload_bytes, 600u);
  EXPECT_EQ(m.sent_bytes, 1000u);
  EXPECT_NEAR(m.latency_median_ms, 200, 1e-6);
  EXPECT_NEAR(m.latency_p95_ms, 290, 1e-6);  // 200 + 0.9 * (300 - 200)
  EXPECT_EQ(m.dropped, 2u);
  EXPECT_EQ(m.resent, 5u);
  EXPECT_DOUBLE_EQ(m.saving_vs_stream_all, 10.0);
  EXPECT_DOUBLE_EQ(m.saving_vs_vslam, 2.0);
  EXPECT_TRUE(m.stream_all_estimated);
  EXPECT_FALSE(m.vslam_keyframe_estimated);
  ASSERT_TRUE(m.wire.has_value());
  EXPECT_EQ(m.wire->tx_bytes, 1500u);
  EXPECT_NEAR(m.throughput_bytes_per_s, 500.0 / 2.1, 1e-9);
}

TEST(RobotMetrics, WithoutAgentStatsOrWireCountersNothingIsInvented) {
  const auto m = robot_metrics("a", {kf("a", 1.0, 1.5, 100)}, std::nullopt, std::nullopt);
  EXPECT_EQ(m.delivered, 1u);
  EXPECT_FALSE(m.agent_stats_seen);
  EXPECT_FALSE(m.wire.has_value());
  EXPECT_DOUBLE_EQ(m.saving_vs_stream_all, 0);
  EXPECT_EQ(robot_metrics("nobody", {}, std::nullopt, std::nullopt).delivered, 0u);
}

TEST(RobotMetrics, LatencyCountsFromTheStreamStartWhenCaptureTimesAreRelative) {
  // Frames stamped 1 s and 2 s into a stream that began at t = 100 s.
  const auto m = robot_metrics("a", {kf("a", 1.0, 101.25, 10), kf("a", 2.0, 102.75, 10)},
                               std::nullopt, std::nullopt, 100 * kSecond);
  EXPECT_NEAR(m.latency_median_ms, 500, 1e-6);
}

TEST(StreamStart, ReadsTheLocalTimeOfTheStationMatchedLine) {
  const auto path = std::filesystem::temp_directory_path() / "keyfleet_stream_start_test.log";
  {
    std::ofstream log(path);
    log << "2024-05-01 17:33:30.900 [drone_0] info streaming from generated\n"
        << "2024-05-01 17:33:31.123 [drone_0] info station matched\n";
  }
  std::tm tm{};
  tm.tm_year = 124;
  tm.tm_mon = 4;
  tm.tm_mday = 1;
  tm.tm_hour = 17;
  tm.tm_min = 33;
  tm.tm_sec = 31;
  tm.tm_isdst = -1;
  const std::int64_t expected = static_cast<std::int64_t>(std::mktime(&tm)) * kSecond + 123'000'000;
  const auto start = stream_start_from_log(path.string());
  ASSERT_TRUE(start.has_value());
  EXPECT_EQ(*start, expected);
  EXPECT_FALSE(stream_start_from_log("/nonexistent.log").has_value());
  std::filesystem::remove(path);
}

TEST(ExperimentConfig, ListsOfNumbersAndOfProfilesRoundTrip) {
  const auto config = parse_bandwidth_experiment_config(R"(
drones: [2, 8]
links: [flow_control]
profiles:
  - name: unlimited
  - name: 500kbit
    rate_kbit_s: 500
    delay_ms: 40
mission:
  agent:
    dds:
      max_bytes_per_s: 1000
)",
                                                        "test.yaml");
  ASSERT_EQ(config.drones, (std::vector<int>{2, 8}));
  ASSERT_EQ(config.profiles.size(), 2u);
  EXPECT_EQ(config.profiles[1].name, "500kbit");
  EXPECT_DOUBLE_EQ(config.profiles[1].rate_kbit_s, 500);
  EXPECT_DOUBLE_EQ(config.profiles[1].delay_ms, 40);
  EXPECT_EQ(config.mission.agent.dds.max_bytes_per_s, 1000u);
  const auto again = parse_bandwidth_experiment_config(to_yaml(config), "round trip");
  EXPECT_EQ(again.drones, config.drones);
  ASSERT_EQ(again.profiles.size(), 2u);
  EXPECT_DOUBLE_EQ(again.profiles[1].rate_kbit_s, 500);
}

// The error a config text gives, or "no error".
std::string error_of(const std::string& yaml) {
  try {
    parse_bandwidth_experiment_config(yaml, "bad.yaml");
  } catch (const ConfigError& e) {
    return std::string(e.what());
  }
  return std::string("no error");
}

TEST(ExperimentConfig, BadProfileKeysAndLinkKindsNameTheKey) {
  EXPECT_NE(error_of("profiles:\n  - name: a\n    rate: 5\n").find("profiles.rate: unknown key"),
            std::string::npos)
      << error_of("profiles:\n  - name: a\n    rate: 5\n");
  EXPECT_NE(error_of("links: [radio]\n").find("links"), std::string::npos);
  EXPECT_NE(error_of("drones: [0]\n").find("drones"), std::string::npos);
  // The name becomes part of a folder under run_root: it may not climb out of it.
  EXPECT_NE(error_of("name: ../../etc\n").find("bad.yaml:1: name: must match"), std::string::npos)
      << error_of("name: ../../etc\n");
}

TEST(ExperimentConfig, RadioKeysAndTheLinkProfileRoundTrip) {
  const auto config = parse_bandwidth_experiment_config(R"(
security: [on, off]
dds_link: false
offered_bytes_per_s: 42000
drain_margin_s: 12
idle_window_s: 4
capture: false
mission:
  agent:
    dds:
      link: {rate_kbit_s: 250, mtu_bytes: 1400, pacing: 0.8, announcement_period_s: 3}
)",
                                                        "radio.yaml");
  EXPECT_EQ(config.security, (std::vector<std::string>{"on", "off"}));
  EXPECT_TRUE(parse_bandwidth_experiment_config("name: x\n", "plain.yaml").security.empty())
      << "by default the mission's own security setting decides";
  EXPECT_FALSE(config.dds_link);
  EXPECT_DOUBLE_EQ(config.offered_bytes_per_s, 42000);
  EXPECT_DOUBLE_EQ(config.drain_margin_s, 12);
  EXPECT_DOUBLE_EQ(config.idle_window_s, 4);
  EXPECT_FALSE(config.capture);
  const DdsLinkProfile& link = config.mission.agent.dds.link;
  EXPECT_DOUBLE_EQ(link.rate_kbit_s, 250);
  EXPECT_EQ(link.mtu_bytes, 1400);
  EXPECT_DOUBLE_EQ(link.pacing, 0.8);
  EXPECT_DOUBLE_EQ(link.announcement_period_s, 3);
  EXPECT_DOUBLE_EQ(link.lease_duration_s, 20) << "unset keys keep their defaults";
  const auto again = parse_bandwidth_experiment_config(to_yaml(config), "round trip");
  EXPECT_EQ(again.security, config.security);
  EXPECT_EQ(again.mission.agent.dds.link.mtu_bytes, 1400);
}

TEST(ExperimentConfig, BadRadioValuesNameTheKey) {
  EXPECT_NE(error_of("security: [maybe]\n").find("security"), std::string::npos);
  EXPECT_NE(error_of("mission: {agent: {dds: {link: {mtu_bytes: 100}}}}\n").find("mtu_bytes"),
            std::string::npos);
  EXPECT_NE(error_of("mission: {agent: {dds: {link: {pacing: 1.5}}}}\n").find("pacing"),
            std::string::npos);
  EXPECT_NE(error_of("mission: {agent: {dds: {link: {rate: 5}}}}\n").find("link.rate: unknown key"),
            std::string::npos)
      << error_of("mission: {agent: {dds: {link: {rate: 5}}}}\n");
}

TEST(DrainSizing, CoversWhatTheFlightOffersOverTheLinkLessItsLoss) {
  BandwidthExperimentConfig config;
  config.offered_bytes_per_s = 60000;
  config.drain_margin_s = 30;
  config.idle_window_s = 10;
  MissionConfig mission;
  mission.agent.source.max_frames = 200;
  mission.agent.source.fps = 10;  // 20 s: 1.2 MB offered
  mission.agent.drain_timeout_s = 60;
  mission.agent.wait_for_station_s = 60;
  mission.agent_timeout_s = 150;
  LinkProfileConfig link;
  link.rate_kbit_s = 100;  // 12,500 B/s, 0.7 of it payload: 8,750 B/s
  MissionConfig clean = mission;
  size_drain(clean, link, config);
  EXPECT_NEAR(clean.agent.drain_timeout_s, 1.2e6 / 8750 - 20 + 30, 1e-9);
  EXPECT_NEAR(clean.agent_timeout_s, 60 + 30 + clean.agent.drain_timeout_s + 10 + 30, 1e-9);
  link.loss_percent = 20;  // a fifth less delivered
  MissionConfig lossy = mission;
  size_drain(lossy, link, config);
  EXPECT_NEAR(lossy.agent.drain_timeout_s, 1.2e6 / 7000 - 20 + 30, 1e-9);
  link.rate_kbit_s = 10000;  // the link outruns the flight: the configured drain stays
  MissionConfig fast = mission;
  size_drain(fast, link, config);
  EXPECT_DOUBLE_EQ(fast.agent.drain_timeout_s, 60);
  EXPECT_DOUBLE_EQ(fast.agent_timeout_s, 60 + 30 + 60 + 10 + 30);
  link.rate_kbit_s = 0;  // no rate: nothing to size
  MissionConfig unlimited = mission;
  size_drain(unlimited, link, config);
  EXPECT_DOUBLE_EQ(unlimited.agent.drain_timeout_s, 60);
  EXPECT_DOUBLE_EQ(unlimited.agent_timeout_s, 150);
}

TEST(DrainSizing, AReplayedScenarioGivesTheFlightItsOwnLength) {
  BandwidthExperimentConfig config;
  config.offered_bytes_per_s = 60000;
  config.drain_margin_s = 30;
  MissionConfig mission;  // a scenario replay: the source has no max_frames
  mission.agent.drain_timeout_s = 60;
  LinkProfileConfig link;
  link.rate_kbit_s = 100;
  MissionConfig without = mission;
  size_drain(without, link, config);  // nothing says how long the flight is: unchanged
  EXPECT_DOUBLE_EQ(without.agent.drain_timeout_s, 60);
  size_drain(mission, link, config, 20.0);  // 20 s of scenario: 1.2 MB offered
  EXPECT_NEAR(mission.agent.drain_timeout_s, 1.2e6 / 8750 - 20 + 30, 1e-9);
}

ExperimentMission analysed(const std::string& name, double rate_kbit_s, bool adapting,
                           std::size_t words_read, std::uint64_t payload_bytes) {
  ExperimentMission m;
  m.name = name;
  m.link = "netns";
  m.drones = 2;
  m.link_adaptation = adapting;
  m.profile.rate_kbit_s = rate_kbit_s;
  for (int i = 0; i < 2; ++i) {
    RobotOutcome r;
    r.metrics.payload_bytes = payload_bytes / 2;
    m.robots.push_back(r);
  }
  MissionAnalysis a;
  a.keyframes = 40;
  a.analysed = 40;
  a.visible_words = 12;
  a.words_read = words_read;
  a.words_read_in_time = rate_kbit_s > 0 && !adapting ? 0 : words_read;
  a.place_matches = 7;
  a.place_matches_right = 6;
  m.analysis = a;
  return m;
}

TEST(AnalysisTable, WordsReadAgainstTheSameFlightOverTheUnlimitedLink) {
  ExperimentResult result;
  result.flight_s = 20;
  result.missions.push_back(analysed("unlimited-adapting", 0, true, 9, 4'000'000));
  result.missions.push_back(analysed("unlimited", 0, false, 10, 4'000'000));
  result.missions.push_back(analysed("slow", 250, false, 4, 1'000'000));
  result.missions.push_back(analysed("slow-adapting", 250, true, 8, 800'000));
  ExperimentMission failed = analysed("no-database", 250, false, 0, 0);
  failed.analysis.reset();
  failed.analysis_error = "not scored against the scenario: cannot open station.sqlite";
  result.missions.push_back(failed);
  const std::string table = analysis_table(result);
  const auto row = [&](const std::string& name) {
    const auto at = table.find("\n" + name + " ");
    return at == std::string::npos ? std::string()
                                   : table.substr(at + 1, table.find('\n', at + 1) - at - 1);
  };
  // The reference is the unlimited flight without adaptation: 10 words.
  EXPECT_NE(row("slow").find("4 of 12"), std::string::npos) << table;
  EXPECT_NE(row("slow").find("40 %"), std::string::npos) << table;
  EXPECT_NE(row("slow-adapting").find("80 %"), std::string::npos) << table;
  EXPECT_NE(row("unlimited-adapting").find("90 %"), std::string::npos) << table;
  // 800 kB over 2 drones and 20 s of flight: 20 kB/s per drone.
  EXPECT_NE(row("slow-adapting").find("20.0"), std::string::npos) << table;
  EXPECT_NE(row("slow").find("7 (6 right)"), std::string::npos) << table;
  // Read in time: none for the fixed agent on the slow link, all for the adapting one.
  EXPECT_NE(row("slow").find("4 of 12        0"), std::string::npos) << table;
  EXPECT_NE(row("slow-adapting").find("8 of 12        8"), std::string::npos) << table;
  EXPECT_NE(table.find("no-database: not scored against the scenario: cannot open"),
            std::string::npos)
      << table;
  EXPECT_NE(experiment_table(result).find("against the scenario's truth"), std::string::npos);
}

TEST(AnalysisTable, InTimeIsADashWhereTheLatencyWasNotMeasured) {
  ExperimentResult result;
  result.flight_s = 20;
  result.missions.push_back(analysed("unlimited", 0, false, 10, 4'000'000));
  result.missions.back().analysis->in_time_known = false;
  const std::string table = analysis_table(result);
  EXPECT_NE(table.find("10 of 12        -"), std::string::npos) << table;
}

TEST(AnalysisTable, NothingWithoutAScenario) {
  ExperimentResult result;
  result.missions.push_back(analysed("plain", 250, false, 0, 1000));
  result.missions.back().analysis.reset();
  EXPECT_EQ(analysis_table(result), "");
}

TEST(ExperimentConfig, AScenarioIsRelativeToTheFileAndMustExist) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("keyfleet_experiment_scenario_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "street.yaml") << "name: street\n";
  std::ofstream(dir / "good.yaml") << "mission:\n  scenario: street.yaml\n";
  std::ofstream(dir / "bad.yaml") << "mission:\n  scenario: missing.yaml\n";
  const auto config = load_bandwidth_experiment_config((dir / "good.yaml").string());
  EXPECT_EQ(std::filesystem::path(config.mission.scenario), dir / "street.yaml");
  try {
    load_bandwidth_experiment_config((dir / "bad.yaml").string());
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mission.scenario: '"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("missing.yaml' does not exist"), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

TEST(LogTime, FindsTheFirstLineWithANeedleOrTheFirstLine) {
  const auto path = std::filesystem::temp_directory_path() / "keyfleet_log_time_test.log";
  {
    std::ofstream log(path);
    log << "2026-05-01 17:33:30.100 [agent drone_0] info effective configuration:\n"
        << "robot_id: drone_0\n"
        << "2026-05-01 17:33:31.000 [agent drone_0] warning no station matched for 60 s\n"
        << "2026-05-01 17:33:31.250 [agent drone_0] info station matched\n"
        << "2026-05-01 17:33:40.000 [agent drone_0] info drained; lingering 10 s\n"
        << "2026-05-01 17:33:50.000 [agent drone_0] info lingering done\n";
  }
  const auto first = log_time_of(path.string(), {});
  const auto matched = log_time_of(path.string(), {"info station matched"});
  const auto linger = log_time_of(path.string(), {"lingering"});
  const auto done = log_time_of(path.string(), {"lingering done"});
  ASSERT_TRUE(first && matched && linger && done);
  EXPECT_EQ(*matched - *first, 1'150'000'000);
  EXPECT_EQ(*done - *linger, 10'000'000'000);
  EXPECT_FALSE(log_time_of(path.string(), {"never logged"}).has_value());
  EXPECT_FALSE(log_time_of("/nonexistent.log", {}).has_value());
  std::filesystem::remove(path);
}

TEST(StationRecords, MissingDatabaseIsAStartupErrorNamingTheFile) {
  try {
    read_station_records("/nonexistent/station.sqlite");
    FAIL() << "no error";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/station.sqlite"), std::string::npos);
  }
}

TEST(RefusedWrites, CountsTheAgentsNotSentNowWarnings) {
  const auto path = std::filesystem::temp_directory_path() / "keyfleet_refused_test.log";
  {
    std::ofstream log(path);
    log << "[info] station matched\n"
        << "[warn] keyframe 3 not sent now (DDS write failed); it stays in the outbox\n"
        << "[warn] keyframe 4 not sent now (DDS write failed); it stays in the outbox\n";
  }
  EXPECT_EQ(count_refused_writes(path.string()), 2u);
  EXPECT_EQ(count_refused_writes("/nonexistent.log"), 0u);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace keyfleet::mission
