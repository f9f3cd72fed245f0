// Bad input gets a clear error, and the station keeps serving everyone else.
#include <csignal>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/text_region_blob.hpp"
#include "keyfleet/dds/dds_transport.hpp"
#include "keyfleet/mission/fleet_credentials.hpp"
#include "support/fleet_fixture.hpp"

namespace keyfleet::testing {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

class BadInput : public FleetFixture {
 protected:
  // Runs robot_agent with `args`, returns (exit status, everything it printed).
  std::pair<mission::ExitStatus, std::string> run_agent(std::vector<std::string> args) {
    return run_binary(KEYFLEET_AGENT_BIN, std::move(args));
  }
  std::pair<mission::ExitStatus, std::string> run_station(std::vector<std::string> args) {
    return run_binary(KEYFLEET_STATION_BIN, std::move(args));
  }
  std::pair<mission::ExitStatus, std::string> run_binary(const std::string& binary,
                                                         std::vector<std::string> args) {
    args.insert(args.begin(), binary);
    const auto log = run_dir_ / ("process-" + std::to_string(++runs_) + ".log");
    mission::ChildProcess process(binary, args, log.string());
    const auto status = process.wait_for(seconds(30));
    EXPECT_TRUE(status.has_value()) << binary << " did not stop on bad input";
    return {status.value_or(mission::ExitStatus{}), read_file(log)};
  }
  std::filesystem::path write_config(const std::string& name, const std::string& text) {
    const auto path = run_dir_ / name;
    std::ofstream(path) << text;
    return path;
  }
  int runs_ = 0;
};

TEST_F(BadInput, MissingConfigFileIsNamed) {
  const auto [status, output] = run_agent({"--config", "/nonexistent/agent.yaml"});
  EXPECT_FALSE(status.ok());
  EXPECT_NE(output.find("/nonexistent/agent.yaml"), std::string::npos) << output;
}

TEST_F(BadInput, UnknownKeyIsNamedWithFileAndLine) {
  const auto path = write_config("typo.yaml", "robot_id: drone_0\nsource:\n  fsp: 30\n");
  const auto [status, output] = run_agent({"--config", path.string()});
  EXPECT_EQ(status.code, 1);
  EXPECT_NE(output.find("typo.yaml:3: source.fsp: unknown key"), std::string::npos) << output;
  EXPECT_NE(output.find("fps"), std::string::npos) << "allowed keys are listed: " << output;
}

TEST_F(BadInput, BadValueSaysWhatIsAllowed) {
  const auto path = write_config("bad.yaml", "codec:\n  jpeg_quality: 150\n");
  const auto [status, output] = run_agent({"--config", path.string()});
  EXPECT_EQ(status.code, 1);
  EXPECT_NE(output.find("codec.jpeg_quality: must be between 1 and 100 (got '150')"),
            std::string::npos)
      << output;
}

TEST_F(BadInput, UnreadableImageFolderIsNamed) {
  const auto path =
      write_config("folder.yaml",
                   "source:\n  kind: folder\n  path: /nonexistent/frames\ndds:\n  security:\n"
                   "    enabled: false\n");
  const auto [status, output] =
      run_agent({"--config", path.string(), "--run-dir", (run_dir_ / "a").string()});
  EXPECT_EQ(status.code, 1);
  EXPECT_NE(output.find("image folder '/nonexistent/frames' does not exist"), std::string::npos)
      << output;
}

// Secure by default: a standalone agent or station whose config says nothing of DDS-Security
// runs with it, and without usable credentials refuses to start, naming what is missing and the
// two ways out; nothing is made in its run folder.
TEST_F(BadInput, AgentWithoutCredentialsRefusesToStart) {
  const auto path = write_config("plain_agent.yaml", "robot_id: drone_0\n");
  const auto run = run_dir_ / "agent-run";
  const auto [status, output] = run_agent({"--config", path.string(), "--run-dir", run.string()});
  EXPECT_EQ(status.code, 1) << output;
  for (const std::string& expected : std::vector<std::string>{
           "robot_agent: error: DDS-Security is on", (run_dir_ / "credentials").string(),
           "does not exist", "keyfleet security init --out DIR", "DIR/hosts/drone_0",
           "dds.security.enabled: false"})
    EXPECT_NE(output.find(expected), std::string::npos) << expected << " in:\n" << output;
  EXPECT_FALSE(std::filesystem::exists(run)) << "nothing is made before the refusal";
}

TEST_F(BadInput, StationWithoutCredentialsRefusesToStart) {
  const auto path = write_config("plain_station.yaml", "report_period_s: 1\n");
  const auto run = run_dir_ / "station-run";
  const auto [status, output] = run_station({"--config", path.string(), "--run-dir", run.string()});
  EXPECT_EQ(status.code, 1) << output;
  for (const std::string& expected :
       std::vector<std::string>{"ground_station: error: DDS-Security is on", "DIR/hosts/station",
                                "dds.security.enabled: false"})
    EXPECT_NE(output.find(expected), std::string::npos) << expected << " in:\n" << output;
  EXPECT_FALSE(std::filesystem::exists(run));
}

TEST_F(BadInput, StationWhoseBundleLacksItsKeyNamesTheFile) {
  mission::write_fleet_credentials({(run_dir_ / "fleet").string(), {"drone_0"}, 1}, null_logger());
  std::filesystem::remove(run_dir_ / "fleet/hosts/station/identities/station.key.pem");
  // A relative folder is taken from the config file's folder.
  const auto path =
      write_config("station.yaml", "dds:\n  security:\n    directory: fleet/hosts/station\n");
  const auto [status, output] =
      run_station({"--config", path.string(), "--run-dir", (run_dir_ / "s").string()});
  EXPECT_EQ(status.code, 1) << output;
  EXPECT_NE(output.find((run_dir_ / "fleet/hosts/station").string() +
                        " lacks identities/station.key.pem (this host's private key"),
            std::string::npos)
      << output;
}

// Security off by the config's word: the station says so at start and in its report.
TEST_F(BadInput, StationWithSecurityOffSaysSoAtStartAndInItsReport) {
  auto station = start_station(station_config());  // the fixture's: dds.security.enabled false
  ASSERT_TRUE(wait_until(
      [&] {
        return read_file(station_dir() / "station.log").find("station ready") != std::string::npos;
      },
      seconds(30)))
      << read_file(station_dir() / "station.log");
  station->signal(SIGTERM);
  const auto status = station->wait_for(seconds(30));
  ASSERT_TRUE(status && status->ok()) << read_file(station_dir() / "station.log");
  EXPECT_NE(read_file(station_dir() / "station.log")
                .find("DDS-Security is off (dds.security.enabled: false)"),
            std::string::npos);
  EXPECT_NE(read_file(station_dir() / "report.txt").find("DDS-Security: off"), std::string::npos)
      << read_file(station_dir() / "report.txt");
  EXPECT_NE(read_file(station_dir() / "report.json").find("\"dds_security\": false"),
            std::string::npos);
}

// Hostile samples published over real DDS next to a well-behaved agent process.
TEST_F(BadInput, StationRejectsHostileSamplesAndKeepsServingOthers) {
  auto station = start_station(station_config());
  auto good_agent = start_agent(agent_config("good_drone"));

  auto link = make_dds_agent_link(dds(), "intruder", null_logger());
  auto bad_id_link = make_dds_agent_link(dds(), "bad_id", null_logger());  // acks: per robot
  ASSERT_TRUE(wait_until(
      [&] { return link->matched_stations() > 0 && bad_id_link->matched_stations() > 0; },
      seconds(20)));

  JpegCodec codec(80);
  const cv::Mat image(48, 64, CV_8UC3, cv::Scalar(40, 120, 200));
  Keyframe valid;
  valid.robot_id = "intruder";
  valid.width = 64;
  valid.height = 48;
  valid.image = codec.encode(image);

  std::vector<Keyframe> hostile;
  Keyframe garbage = valid;  // not a JPEG at all
  garbage.sequence_number = 0;
  garbage.image.assign(5000, 0xAB);
  hostile.push_back(garbage);
  Keyframe truncated = valid;  // a real JPEG cut in half
  truncated.sequence_number = 1;
  truncated.image.resize(valid.image.size() / 2);
  hostile.push_back(truncated);
  Keyframe absurd = valid;  // claims a 100000 x 100000 frame
  absurd.sequence_number = 2;
  absurd.width = absurd.height = 100000;
  hostile.push_back(absurd);
  Keyframe lying_header = valid;  // header edited to 30000 x 30000, claim matches
  lying_header.sequence_number = 3;
  for (std::size_t i = 2; i + 8 < lying_header.image.size(); ++i) {
    if (lying_header.image[i] == 0xFF && lying_header.image[i + 1] == 0xC0) {
      lying_header.image[i + 5] = 0x75, lying_header.image[i + 6] = 0x30;
      lying_header.image[i + 7] = 0x75, lying_header.image[i + 8] = 0x30;
      break;
    }
  }
  lying_header.width = lying_header.height = 30000;
  hostile.push_back(lying_header);
  Keyframe empty = valid;
  empty.sequence_number = 4;
  empty.image.clear();
  hostile.push_back(empty);
  Keyframe bad_id = valid;  // a robot id outside the allowed format
  bad_id.robot_id = "../../etc/passwd";

  // Like an agent's outbox, publish again whatever is not acknowledged yet: a sample
  // written while the station's reader is still matching this writer may not reach it.
  std::map<std::uint64_t, KeyframeAck> acks;
  std::vector<KeyframeAck> bad_id_acks;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& k : hostile)
          if (!acks.count(k.sequence_number)) link->publish(k);
        if (bad_id_acks.empty()) bad_id_link->publish(bad_id);
        for (auto& ack : link->take_acks("intruder", milliseconds(300)))
          acks[ack.sequence_number] = ack;
        for (auto& ack : bad_id_link->take_acks(bad_id.robot_id, milliseconds(0)))
          bad_id_acks.push_back(ack);
        return acks.size() == hostile.size() && !bad_id_acks.empty();
      },
      seconds(20)));
  for (const auto& [sequence, ack] : acks) {
    EXPECT_EQ(ack.status, AckStatus::kRejected) << sequence;
    EXPECT_FALSE(ack.reason.empty());
  }
  EXPECT_NE(bad_id_acks.front().reason.find("robot id"), std::string::npos);

  // The well-behaved agent is served in full.
  const auto status = good_agent->wait_for(seconds(60));
  ASSERT_TRUE(status && status->ok()) << mission::tail_of_file(good_agent->log_path(), 20);
  EXPECT_EQ(stored_counts()["good_drone"], 12);
  EXPECT_EQ(stored_counts().count("intruder"), 0u);
  EXPECT_FALSE(station->poll().has_value()) << "the station died";

  const auto reasons = rejection_reasons();
  ASSERT_EQ(reasons.size(), hostile.size() + 1);
  auto mentions = [&](const std::string& what) {
    for (const auto& r : reasons)
      if (r.find(what) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(mentions("not a JPEG") || mentions("no start-of-frame")) << reasons[0];
  EXPECT_TRUE(mentions("truncated JPEG"));
  EXPECT_TRUE(mentions("claimed size 100000x100000"));
  EXPECT_TRUE(mentions("claimed size 30000x30000"));
  EXPECT_TRUE(mentions("empty image"));

  station->signal(SIGTERM);
  const auto station_status = station->wait_for(seconds(30));
  ASSERT_TRUE(station_status && station_status->ok());
}

// Text regions that lie, over real DDS: the keyframe is still stored and acknowledged, with its
// regions fixed (cut at the image's edge, outside or empty ones dropped, capped in number).
TEST_F(BadInput, KeyframeWithLyingTextRegionsIsStoredWithThemFixed) {
  auto station = start_station(station_config());
  auto link = make_dds_agent_link(dds(), "hinter", null_logger());
  ASSERT_TRUE(wait_until([&] { return link->matched_stations() > 0; }, seconds(20)));

  JpegCodec codec(80);
  Keyframe k;
  k.robot_id = "hinter";
  k.width = 64;
  k.height = 48;
  k.image = codec.encode(cv::Mat(48, 64, CV_8UC3, cv::Scalar(40, 120, 200)));
  k.text_regions = {{10, 10, 20, 8}, {60, 40, 60000, 60000}, {65535, 0, 5, 5}, {0, 0, 0, 0}};
  k.text_regions.resize(5000, TextRegion{1, 1, 2, 2});
  std::optional<KeyframeAck> ack;
  ASSERT_TRUE(wait_until(
      [&] {
        if (!ack) link->publish(k);
        // The first ack: a copy published again before it arrived is acked as a duplicate.
        for (auto& a : link->take_acks("hinter", milliseconds(300)))
          if (!ack) ack = a;
        return ack.has_value();
      },
      seconds(20)));
  EXPECT_EQ(ack->status, AckStatus::kStored) << ack->reason;

  std::vector<TextRegion> expected = {{10, 10, 20, 8}, {60, 40, 4, 8}};
  expected.resize(64, TextRegion{1, 1, 2, 2});  // limits.max_text_regions
  {
    SqliteDb db((station_dir() / "station.sqlite").string(), SqliteDb::Mode::kReadOnly);
    auto q = db.prepare("SELECT text_regions FROM keyframes WHERE robot_id='hinter'");
    ASSERT_TRUE(q.step());
    EXPECT_TRUE(text_regions_from_blob(q.blob(0)) == expected);
  }
  station->signal(SIGTERM);
  const auto station_status = station->wait_for(seconds(30));
  ASSERT_TRUE(station_status && station_status->ok());
  const std::string log = read_file(station_dir() / "station.log");
  EXPECT_NE(log.find("text regions 2 dropped"), std::string::npos) << log;
}

}  // namespace
}  // namespace keyfleet::testing
