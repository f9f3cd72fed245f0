// The station's analysis end to end: a generated 2-drone street mission through real agents,
// real DDS and the real engines (Tesseract, ORB bag of words + VFC), then the run's words,
// place matches, exported map, the query/locate/map commands, and a station restart.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

namespace fs = std::filesystem;
using std::chrono::seconds;

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

class StationAnalysisMission : public FleetFixture {
 protected:
  // Runs `keyfleet ARGS...`; returns exit status and output.
  std::pair<mission::ExitStatus, std::string> cli(const std::vector<std::string>& args,
                                                  const std::string& name, seconds timeout) {
    std::vector<std::string> argv{KEYFLEET_CLI_BIN};
    argv.insert(argv.end(), args.begin(), args.end());
    const auto log = run_dir_ / (name + ".out");
    mission::ChildProcess process(name, argv, log.string());
    const auto status = process.wait_for(timeout);
    EXPECT_TRUE(status.has_value()) << "keyfleet " << name << " did not finish";
    return {status.value_or(mission::ExitStatus{}), read_file(log)};
  }
};

TEST_F(StationAnalysisMission, WordsPlacesAndMapFromAGeneratedMissionSurviveARestart) {
  std::ofstream(run_dir_ / "scenario.yaml")
      << "name: analysis\nframes_per_drone: 90\nstreet: {length_m: 40}\n"
         "drones: {count: 2, days: 2}\n";
  std::ofstream(run_dir_ / "mission.yaml")
      << "name: analysis\nscenario: scenario.yaml\nrun_root: " << (run_dir_ / "runs").string()
      << "\nagent:\n  source: {realtime: false}\n"
         "  selector: {strategy: vslam, trigger: {kind: stride, stride: 10}}\n"
         "  dds: {lease_duration_s: 2, announcement_period_s: 0.5}\n"
         "station:\n  analysis: {drain_timeout_s: 120}\n"
         "station_drain_timeout_s: 150\n";
  const auto [status, output] =
      cli({"mission", (run_dir_ / "mission.yaml").string()}, "mission", seconds(400));
  ASSERT_TRUE(status.ok()) << output;

  std::smatch m;
  ASSERT_TRUE(std::regex_search(output, m, std::regex(R"(run folder: (\S+))"))) << output;
  const fs::path run = m[1].str();
  const fs::path station = run / "station";
  ASSERT_TRUE(std::regex_search(output, m, std::regex(R"(Station analysis: (\d+) keyframe)")))
      << output;
  EXPECT_EQ(std::stoi(m[1].str()), 18) << "every keyframe analysed before the station stopped";
  ASSERT_TRUE(std::regex_search(output, m, std::regex(R"(words read: (\d+))"))) << output;
  EXPECT_GT(std::stoi(m[1].str()), 0) << output;
  ASSERT_TRUE(std::regex_search(output, m, std::regex(R"(\((\d+) across robots\))"))) << output;
  const int cross_robot = std::stoi(m[1].str());
  EXPECT_GT(cross_robot, 0) << "the two drones fly the same street: places must match\n" << output;

  // Words read are words on the generated signs (ground truth), not only noise.
  std::set<std::string> truth;
  for (const auto& sign : scenario::read_scenario((run / "scenario").string()).signs)
    if (sign.legible) truth.insert(upper(sign.text));
  SqliteDb db((station / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
  auto words = db.prepare("SELECT DISTINCT upper(text) FROM words");
  std::vector<std::string> correct;
  while (words.step())
    if (truth.count(words.text(0))) correct.push_back(words.text(0));
  ASSERT_FALSE(correct.empty()) << "no word read matches a sign of the scenario";

  // Every place match joins keyframes whose true camera positions are close.
  auto matches = db.prepare(
      "SELECT a.pose_tx - b.pose_tx, a.pose_ty - b.pose_ty FROM place_matches p "
      "JOIN keyframes a ON a.robot_id = p.robot_id AND a.sequence_number = p.sequence_number "
      "JOIN keyframes b ON b.robot_id = p.match_robot_id AND "
      "b.sequence_number = p.match_sequence_number");
  while (matches.step()) {
    EXPECT_LT(std::hypot(matches.real(0), matches.real(1)), 10.0)
        << "a place match between cameras more than 10 m apart";
  }

  // The exported map holds every keyframe and the place edges.
  const auto map = nlohmann::json::parse(read_file(station / "map.json"));
  EXPECT_EQ(map["nodes"].size(), 18u);
  EXPECT_NE(read_file(station / "map.graphml").find("<graphml"), std::string::npos);

  // Queries: a word read, a frame relocalised, the robots at a matched place.
  const auto [query_status, query_out] =
      cli({"query", "words", correct.front(), "--run", run.string()}, "query", seconds(60));
  EXPECT_TRUE(query_status.ok()) << query_out;
  EXPECT_NE(query_out.find("drone_"), std::string::npos) << query_out;

  const auto frames = scenario::read_frame_truth((run / "scenario" / "drone_1").string());
  const fs::path frame = run / "scenario" / "drone_1" / frames[45].image;
  const auto [locate_status, locate_out] =
      cli({"locate", frame.string(), "--run", run.string()}, "locate", seconds(60));
  EXPECT_TRUE(locate_status.ok()) << locate_out;
  EXPECT_NE(locate_out.find("located: drone_"), std::string::npos) << locate_out;

  // A restarted station reloads its map and place index from the database.
  StationConfig config = station_config();
  config.analysis.drain_timeout_s = 5;
  std::ofstream(run_dir_ / "restart.yaml") << to_yaml(config);
  auto restarted = [&] {
    return std::make_unique<mission::ChildProcess>(
        "ground_station",
        std::vector<std::string>{
            KEYFLEET_STATION_BIN, "--config", (run_dir_ / "restart.yaml").string(), "--run-dir",
            station.string(), "--log-file", (run_dir_ / "restart.log").string()},
        (run_dir_ / "restart.out").string());
  }();
  ASSERT_TRUE(wait_until(
      [&] {
        return read_file(run_dir_ / "restart.log").find("station ready") != std::string::npos;
      },
      seconds(60)))
      << read_file(run_dir_ / "restart.out");
  restarted->signal(SIGTERM);
  const auto restart_status = restarted->wait_for(seconds(60));
  ASSERT_TRUE(restart_status && restart_status->ok()) << read_file(run_dir_ / "restart.out");
  const std::string log = read_file(run_dir_ / "restart.log");
  EXPECT_TRUE(std::regex_search(log, std::regex(R"(restored 18 keyframe\(s\))"))) << log;
  EXPECT_NE(read_file(station / "report.txt").find("across robots"), std::string::npos);
}

}  // namespace
}  // namespace keyfleet::testing
