// `keyfleet mission` end to end: it runs the fleet, prints the report, and names a
// failing process with the reason.
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "keyfleet/common/sqlite.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::seconds;

class MissionCommand : public FleetFixture {
 protected:
  std::pair<mission::ExitStatus, std::string> run_mission(const std::string& yaml) {
    const auto config = run_dir_ / "mission.yaml";
    std::ofstream(config) << yaml;
    const auto log = run_dir_ / "mission.out";
    mission::ChildProcess cli("keyfleet", {KEYFLEET_CLI_BIN, "mission", config.string()},
                              log.string());
    const auto status = cli.wait_for(seconds(180));
    EXPECT_TRUE(status.has_value()) << "keyfleet mission did not finish";
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    return {status.value_or(mission::ExitStatus{}), text.str()};
  }

  std::string base_yaml(int drones) const {
    std::ostringstream y;
    y << "name: citest\ndrones: " << drones << "\nrun_root: " << (run_dir_ / "runs").string()
      << "\nagent:\n  source: {kind: generated, realtime: false, max_frames: 40, width: 320, "
         "height: 240}\n  selector: {strategy: vslam, trigger: {kind: stride, stride: 10}}\n  dds: "
         "{lease_duration_s: 2, "
         "announcement_period_s: 0.5}\nstation: {analysis: {drain_timeout_s: 2}}\n";
    return y.str();
  }
};

TEST_F(MissionCommand, TwoDroneMissionPrintsReportAndSucceeds) {
  const auto [status, output] = run_mission(base_yaml(2));
  EXPECT_TRUE(status.ok()) << output;
  EXPECT_NE(output.find("mission OK"), std::string::npos) << output;
  // Each drone: 40 frames, stride 10 -> 4 keyframes stored.
  EXPECT_TRUE(std::regex_search(output, std::regex(R"(drone_0\s+4\s+0\s)"))) << output;
  EXPECT_TRUE(std::regex_search(output, std::regex(R"(drone_1\s+4\s+0\s)"))) << output;
  EXPECT_TRUE(std::regex_search(output, std::regex(R"(FLEET\s+8\s+0\s)"))) << output;
  std::smatch run_folder;
  ASSERT_TRUE(std::regex_search(output, run_folder, std::regex(R"(run folder: (\S+))")));
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(run_folder[1].str()) / "station" /
                                      "report.json"));
  // The station it ran serves this mission's drones only.
  const StationConfig station = load_station_config(
      (std::filesystem::path(run_folder[1].str()) / "config" / "station.yaml").string());
  EXPECT_EQ(station.limits.allowed_robots, (std::vector<std::string>{"drone_0", "drone_1"}));
  // Each process got its host's bundle only: its own key, no other host's, not the CA's.
  const std::filesystem::path run(run_folder[1].str());
  const auto files_in = [](const std::filesystem::path& dir) {
    std::set<std::string> files;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(dir))
      if (entry.is_regular_file())
        files.insert(std::filesystem::relative(entry.path(), dir).string());
    return files;
  };
  for (const std::string id : {"drone_0", "drone_1"}) {
    const AgentConfig agent = load_agent_config((run / "config" / (id + ".yaml")).string());
    EXPECT_TRUE(agent.dds.security.enabled);
    EXPECT_EQ(agent.dds.security.directory, (run / "security" / "hosts" / id).string());
    EXPECT_EQ(files_in(agent.dds.security.directory),
              (std::set<std::string>{
                  "ca.cert.pem", "governance.p7s", "identities/" + id + ".cert.pem",
                  "identities/" + id + ".key.pem", "identities/" + id + ".permissions.p7s"}));
  }
  EXPECT_EQ(station.dds.security.directory, (run / "security" / "hosts" / "station").string());
  EXPECT_EQ(files_in(station.dds.security.directory),
            (std::set<std::string>{"ca.cert.pem", "fleet.txt", "governance.p7s",
                                   "identities/station.cert.pem", "identities/station.key.pem",
                                   "identities/station.permissions.p7s"}));
  // Nothing of the run is readable by other users: the folders, the keyframes, the reports.
  const auto others = std::filesystem::perms::group_all | std::filesystem::perms::others_all;
  for (const auto& path : {run, run / "station", run / "station" / "station.sqlite",
                           run / "station" / "report.json", run / "drone_0" / "outbox.sqlite"}) {
    ASSERT_TRUE(std::filesystem::exists(path)) << path;
    EXPECT_EQ(std::filesystem::status(path).permissions() & others, std::filesystem::perms::none)
        << path << " is readable by others";
  }
}

TEST_F(MissionCommand, FailingAgentIsNamedWithItsReason) {
  std::string yaml = base_yaml(2);
  yaml = std::regex_replace(yaml, std::regex("kind: generated"),
                            "kind: folder, path: /nonexistent/frames");
  const auto [status, output] = run_mission(yaml);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(output.find("mission FAILED"), std::string::npos) << output;
  EXPECT_NE(output.find("drone_0 (pid"), std::string::npos) << output;
  EXPECT_NE(output.find("exited with code 1"), std::string::npos) << output;
  EXPECT_NE(output.find("/nonexistent/frames"), std::string::npos) << output;
}

TEST_F(MissionCommand, GeneratesAScenarioAndReplaysEachDroneWithItsPoses) {
  std::ofstream(run_dir_ / "scenario.yaml")
      << "name: tiny\nframes_per_drone: 30\nwidth: 320\nheight: 240\n"
         "street: {length_m: 40}\ndrones: {count: 2}\n";
  std::ostringstream y;
  y << "name: scen\nscenario: scenario.yaml\nrun_root: " << (run_dir_ / "runs").string()
    << "\nagent:\n  source: {realtime: false}\n  selector: {strategy: vslam, trigger: {kind: "
       "stride, stride: 10}}\n"
       "  dds: {lease_duration_s: 2, announcement_period_s: 0.5}\n"
       "station: {analysis: {drain_timeout_s: 2}}\n";
  const auto [status, output] = run_mission(y.str());
  ASSERT_TRUE(status.ok()) << output;
  EXPECT_TRUE(std::regex_search(output, std::regex(R"(drone_0\s+3\s+0\s)"))) << output;
  EXPECT_TRUE(std::regex_search(output, std::regex(R"(drone_1\s+3\s+0\s)"))) << output;
  std::smatch run_folder;
  ASSERT_TRUE(std::regex_search(output, run_folder, std::regex(R"(run folder: (\S+))")));
  const auto db = std::filesystem::path(run_folder[1].str()) / "station" / "station.sqlite";
  SqliteDb store(db.string(), SqliteDb::Mode::kReadOnly);
  auto q = store.prepare("SELECT COUNT(*) FROM keyframes WHERE pose_tx IS NOT NULL");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.int64(0), 6) << "keyframes from a scenario carry the true camera pose";

  // The station served its dashboard, and the run folder has a report.html with the scenario's
  // ground truth under each keyframe.
  EXPECT_TRUE(std::regex_search(output, std::regex(R"(dashboard: http://127\.0\.0\.1:\d+/)")))
      << output;
  std::ifstream html(std::filesystem::path(run_folder[1].str()) / "report.html");
  std::stringstream text;
  text << html.rdbuf();
  EXPECT_NE(text.str().find("truth:"), std::string::npos);
  EXPECT_NE(text.str().find("data:image/jpeg;base64,"), std::string::npos);
  EXPECT_NE(text.str().find("placed by pose"), std::string::npos);
}

// `keyfleet bench fleet` runs (one agent, a tiny scenario, both modes) and prints its tables;
// its timings are figures, not checked here.
TEST_F(MissionCommand, BenchFleetRunsOneAgentInBothModesAndPrintsItsTables) {
  std::ofstream(run_dir_ / "scenario.yaml")
      << "name: tiny\nframes_per_drone: 20\nwidth: 320\nheight: 240\n"
         "street: {length_m: 30}\ndrones: {count: 1}\n";
  std::ofstream(run_dir_ / "mission.yaml")
      << "name: bench\nscenario: scenario.yaml\nagent:\n  selector: {strategy: quality, trigger: "
         "{kind: klt}}\n  dds: {lease_duration_s: 2, announcement_period_s: 0.5}\n"
         "station: {analysis: {drain_timeout_s: 2}}\n";
  const auto log = run_dir_ / "bench.out";
  mission::ChildProcess cli(
      "keyfleet",
      {KEYFLEET_CLI_BIN, "bench", "fleet", (run_dir_ / "mission.yaml").string(), "--drones", "1",
       "--mode", "both", "--out", (run_dir_ / "runs").string()},
      log.string());
  const auto status = cli.wait_for(seconds(180));
  ASSERT_TRUE(status.has_value()) << "keyfleet bench fleet did not finish";
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  const std::string output = text.str();
  EXPECT_TRUE(status->ok()) << output;
  EXPECT_TRUE(
      std::regex_search(output, std::regex(R"(realtime\s+1\s+[0-9.]+\s+[0-9.]+\s+[0-9.]+\s+20\s)")))
      << output;
  EXPECT_TRUE(
      std::regex_search(output, std::regex(R"(fast\s+1\s+[0-9.]+\s+[0-9.]+\s+[0-9.]+\s+20\s)")))
      << output;
  EXPECT_NE(output.find("largest N at real time"), std::string::npos) << output;
  EXPECT_NE(output.find("trigger"), std::string::npos) << "no per-stage table: " << output;
}

}  // namespace
}  // namespace keyfleet::testing
