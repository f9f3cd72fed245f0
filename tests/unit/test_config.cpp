// Configuration parsing: defaults, precise error messages, round trips, shipped files.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>

#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/eval/eval_config.hpp"
#include "keyfleet/mission/experiment_config.hpp"
#include "keyfleet/mission/mission_config.hpp"
#include "keyfleet/scenario/scenario_config.hpp"
#include "keyfleet/station/station_config.hpp"

namespace keyfleet {
namespace {

// The message of the ConfigError that `parse` throws; fails the test when none is thrown.
template <class Parse>
std::string config_error_of(Parse parse) {
  try {
    parse();
  } catch (const ConfigError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected ConfigError, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected ConfigError, nothing was thrown";
  return {};
}

std::string agent_error(const std::string& text) {
  return config_error_of([&] { parse_agent_config(text, "agent.yaml"); });
}

// A small agent document that changes one value.
constexpr const char* kMinimalAgent = "source:\n  max_frames: 10\n";

TEST(ConfigDefaults, EmptyStationDocumentGivesDefaults) {
  const StationConfig parsed = parse_station_config("", "station.yaml");
  const StationConfig defaults;
  EXPECT_EQ(parsed.database, defaults.database);
  EXPECT_EQ(parsed.mission_log, defaults.mission_log);
  EXPECT_EQ(parsed.report_period_s, defaults.report_period_s);
  EXPECT_EQ(parsed.log_level, defaults.log_level);
  EXPECT_EQ(parsed.limits.max_image_bytes, defaults.limits.max_image_bytes);
  EXPECT_EQ(parsed.limits.max_width, defaults.limits.max_width);
  EXPECT_EQ(parsed.dds.domain_id, defaults.dds.domain_id);
  EXPECT_EQ(parsed.dds.partition, defaults.dds.partition);
  EXPECT_EQ(parsed.dds.transport, defaults.dds.transport);
}

TEST(ConfigDefaults, AgentDocumentWithOnlyMaxFramesKeepsEveryOtherDefault) {
  const AgentConfig parsed = parse_agent_config(kMinimalAgent, "agent.yaml");
  const AgentConfig defaults;
  EXPECT_EQ(parsed.source.max_frames, 10u);
  EXPECT_EQ(parsed.robot_id, defaults.robot_id);
  EXPECT_EQ(parsed.source.kind, defaults.source.kind);
  EXPECT_EQ(parsed.source.fps, defaults.source.fps);
  EXPECT_EQ(parsed.source.width, defaults.source.width);
  EXPECT_EQ(parsed.selector.trigger.stride, defaults.selector.trigger.stride);
  EXPECT_EQ(parsed.codec.jpeg_quality, defaults.codec.jpeg_quality);
  EXPECT_EQ(parsed.ledger.baseline_sample_every, defaults.ledger.baseline_sample_every);
  EXPECT_EQ(parsed.outbox.path, defaults.outbox.path);
  EXPECT_EQ(parsed.outbox.max_pending, defaults.outbox.max_pending);
  EXPECT_EQ(parsed.outbox.resend_after_s, defaults.outbox.resend_after_s);
  EXPECT_EQ(parsed.dds.domain_id, defaults.dds.domain_id);
  EXPECT_EQ(parsed.log_level, defaults.log_level);
}

TEST(ConfigDefaults, EmptyAgentDocumentGivesDefaultsWithAnEndlessGeneratedFlight) {
  const AgentConfig parsed = parse_agent_config("", "agent.yaml");
  EXPECT_EQ(parsed.robot_id, AgentConfig{}.robot_id);
  EXPECT_EQ(parsed.source.kind, SourceConfig::Kind::kGenerated);
  EXPECT_EQ(parsed.source.max_frames, 0u);
}

TEST(ConfigBadValue, HugeOutboxDurationsAreRejectedBeforeTheyOverflow) {
  const std::string message = agent_error("outbox:\n  max_age_s: 1e12\n");
  EXPECT_NE(message.find("outbox.max_age_s: must be between"), std::string::npos) << message;
}

TEST(ConfigDefaults, MissionDocumentWithOnlyAgentMaxFramesKeepsDefaults) {
  const MissionConfig parsed =
      parse_mission_config("agent:\n  source:\n    max_frames: 5\n", "mission.yaml");
  const MissionConfig defaults;
  EXPECT_EQ(parsed.name, defaults.name);
  EXPECT_EQ(parsed.drones, defaults.drones);
  EXPECT_EQ(parsed.robot_id_prefix, defaults.robot_id_prefix);
  EXPECT_FALSE(parsed.domain_id.has_value());
  EXPECT_EQ(parsed.agent.source.max_frames, 5u);
  EXPECT_EQ(parsed.station.database, defaults.station.database);
}

TEST(ConfigUnknownKey, NestedUnknownKeyNamesOriginLineDottedPathAndAllowedKeys) {
  const std::string message =
      agent_error("robot_id: drone_1\nsource:\n  fpss: 30\n  max_frames: 10\n");
  EXPECT_NE(message.find("agent.yaml:3: source.fpss: unknown key"), std::string::npos) << message;
  EXPECT_NE(message.find("fps"), std::string::npos) << message;
  EXPECT_NE(message.find("max_frames"), std::string::npos) << message;
  EXPECT_NE(message.find("seed"), std::string::npos) << message;
}

TEST(ConfigUnknownKey, TopLevelUnknownKeyHasNoDottedPrefix) {
  const std::string message = agent_error("robot_idd: drone_1\n");
  EXPECT_NE(message.find("agent.yaml:1: robot_idd: unknown key"), std::string::npos) << message;
  EXPECT_NE(message.find("robot_id"), std::string::npos) << message;
}

TEST(ConfigUnknownKey, MissionUnknownKeyShowsFullPathThroughAgentSection) {
  const std::string message = config_error_of([] {
    parse_mission_config("name: m\nagent:\n  source:\n    max_frames: 5\n    bogus: 1\n",
                         "mission.yaml");
  });
  EXPECT_NE(message.find("mission.yaml:5: agent.source.bogus: unknown key"), std::string::npos)
      << message;
}

TEST(ConfigUnknownKey, DocumentThatIsNotAMappingIsRejected) {
  for (const char* text : {"hello\n", "- a\n- b\n"}) {
    const std::string message = agent_error(text);
    EXPECT_NE(message.find("agent.yaml:1:"), std::string::npos) << message;
    EXPECT_NE(message.find("expected a mapping"), std::string::npos) << message;
  }
}

TEST(ConfigUnknownKey, NonScalarKeyGivesConfigErrorNamingOrigin) {
  const std::string message = agent_error("source:\n  max_frames: 3\n  {x: 1}: 2\n");
  EXPECT_NE(message.find("agent.yaml:3"), std::string::npos) << message;
  EXPECT_NE(message.find("keys must be plain names"), std::string::npos) << message;
}

TEST(ConfigUnknownKey, TopLevelThatIsNotAMappingSaysSo) {
  const std::string message = agent_error("hello\n");
  EXPECT_NE(message.find("agent.yaml:1: (top level): expected a mapping"), std::string::npos)
      << message;
}

TEST(ConfigUnknownKey, StationUnknownKeyInLimitsIsRejected) {
  const std::string message =
      config_error_of([] { parse_station_config("limits:\n  max_widht: 10\n", "station.yaml"); });
  EXPECT_NE(message.find("station.yaml:2: limits.max_widht: unknown key"), std::string::npos)
      << message;
  EXPECT_NE(message.find("max_width"), std::string::npos) << message;
}

struct BadValueCase {
  const char* name;
  const char* yaml;
  const char* expected_where;    // origin:line: key
  const char* expected_allowed;  // what the message says is allowed
};

class ConfigBadAgentValue : public ::testing::TestWithParam<BadValueCase> {};

TEST_P(ConfigBadAgentValue, IsRejectedWithKeyLineAndWhatIsAllowed) {
  const BadValueCase& c = GetParam();
  const std::string message = agent_error(c.yaml);
  EXPECT_NE(message.find(c.expected_where), std::string::npos) << message;
  EXPECT_NE(message.find(c.expected_allowed), std::string::npos) << message;
}

INSTANTIATE_TEST_SUITE_P(
    Values, ConfigBadAgentValue,
    ::testing::Values(
        BadValueCase{"NegativeFps", "source:\n  max_frames: 10\n  fps: -5\n",
                     "agent.yaml:3: source.fps", "must be between 0.1 and 1000"},
        BadValueCase{"JpegQualityZero", "source:\n  max_frames: 10\ncodec:\n  jpeg_quality: 0\n",
                     "agent.yaml:4: codec.jpeg_quality", "must be between 1 and 100"},
        BadValueCase{"JpegQuality101", "source:\n  max_frames: 10\ncodec:\n  jpeg_quality: 101\n",
                     "agent.yaml:4: codec.jpeg_quality", "must be between 1 and 100"},
        BadValueCase{"UnknownSourceKind", "source:\n  max_frames: 10\n  kind: camera\n",
                     "agent.yaml:3: source.kind", "generated|folder|video"},
        BadValueCase{"NegativeUnsigned", "source:\n  max_frames: -3\n",
                     "agent.yaml:2: source.max_frames", "must not be negative"},
        BadValueCase{"StringForNumber", "source:\n  max_frames: 10\n  fps: fast\n",
                     "agent.yaml:3: source.fps", "expected a number"},
        BadValueCase{"StringForInteger", "source:\n  max_frames: ten\n",
                     "agent.yaml:2: source.max_frames", "expected an integer"},
        BadValueCase{"DomainIdTooLarge", "source:\n  max_frames: 10\ndds:\n  domain_id: 300\n",
                     "agent.yaml:4: dds.domain_id", "must be between 0 and 232"},
        BadValueCase{"UnknownTransport",
                     "source:\n  max_frames: 10\ndds:\n  transport: carrier_pigeon\n",
                     "agent.yaml:4: dds.transport", "localhost|network"},
        BadValueCase{"BadRobotId", "robot_id: \"bad id!\"\nsource:\n  max_frames: 10\n",
                     "agent.yaml:1: robot_id", "[A-Za-z0-9_-]{1,32}"},
        BadValueCase{"UnknownLogLevel", "source:\n  max_frames: 10\nlog_level: loud\n",
                     "agent.yaml:3: log_level", "must be one of"},
        BadValueCase{"ZeroMaxPending", "source:\n  max_frames: 10\noutbox:\n  max_pending: 0\n",
                     "agent.yaml:4: outbox.max_pending", "must be >= 1"},
        BadValueCase{"SectionIsNotAMapping", "source: 12\n", "agent.yaml:1: source",
                     "expected a mapping"},
        BadValueCase{"ListForScalar", "source:\n  max_frames: 10\n  fps: [1, 2]\n",
                     "agent.yaml:3: source.fps", "expected a single value"},
        BadValueCase{"NanResendTimeout",
                     "source:\n  max_frames: 10\noutbox:\n  resend_after_s: .nan\n",
                     "agent.yaml:4: outbox.resend_after_s", "must be a finite number"},
        BadValueCase{"InfiniteStationWait", "source:\n  max_frames: 10\nwait_for_station_s: .inf\n",
                     "agent.yaml:3: wait_for_station_s", "must be a finite number"},
        BadValueCase{"NegativeInfiniteEdgeContrast",
                     "source:\n  max_frames: 10\nselector:\n  quality:\n    edge_contrast: -.inf\n",
                     "agent.yaml:5: selector.quality.edge_contrast", "must be a finite number"},
        BadValueCase{"NanKltMaxError",
                     "selector:\n  trigger:\n    kind: klt\n    klt:\n      max_error: .nan\n",
                     "agent.yaml:5: selector.trigger.klt.max_error", "must be a finite number"},
        BadValueCase{"KltWindowTooSmall", "selector:\n  trigger:\n    klt:\n      window_px: 3\n",
                     "agent.yaml:4: selector.trigger.klt.window_px", "must be between 5 and 101"},
        BadValueCase{"UnknownTriggerKind", "selector:\n  trigger:\n    kind: lidar\n",
                     "agent.yaml:3: selector.trigger.kind", "orbslam|klt|stride|list"},
        BadValueCase{"DecodeReduceNotADctScale", "selector:\n  decode_reduce: 3\n",
                     "agent.yaml:2: selector.decode_reduce", "must be 1, 2, 4 or 8"}),
    [](const ::testing::TestParamInfo<BadValueCase>& info) { return info.param.name; });

TEST(ConfigBadValue, StationDomainIdOutOfRangeNamesKey) {
  const std::string message =
      config_error_of([] { parse_station_config("dds:\n  domain_id: 300\n", "station.yaml"); });
  EXPECT_NE(message.find("station.yaml:2: dds.domain_id"), std::string::npos) << message;
  EXPECT_NE(message.find("must be between 0 and 232"), std::string::npos) << message;
}

TEST(ConfigBadValue, StationUnknownVerifierNamesKeyAndChoices) {
  const std::string message = config_error_of(
      [] { parse_station_config("analysis:\n  places:\n    verifier: magic\n", "station.yaml"); });
  EXPECT_NE(message.find("station.yaml:3: analysis.places.verifier"), std::string::npos) << message;
  EXPECT_NE(message.find("ransac_homography"), std::string::npos) << message;
}

TEST(ConfigBadValue, PpocrSettingsAreChecked) {
  const auto text = [](const std::string& line) {
    return "analysis:\n  text:\n    " + line + "\n";
  };
  EXPECT_EQ(parse_station_config(text("ppocr_detector_size: 1280x736"), "station.yaml")
                .analysis.text.ppocr.detector_size,
            "1280x736");
  EXPECT_EQ(parse_station_config(text("ppocr_keyframe_detector: kf/ppocr_det_512x384_tuned.onnx"),
                                 "station.yaml")
                .analysis.text.ppocr.keyframe_detector,
            "kf/ppocr_det_512x384_tuned.onnx");
  EXPECT_EQ(StationConfig{}.analysis.text.ppocr.keyframe_detector, "");
  for (const std::string bad : {"650x480", "640", "640x480x3", "0x480", "8192x480"}) {
    const std::string message = config_error_of(
        [&] { parse_station_config(text("ppocr_detector_size: " + bad), "station.yaml"); });
    EXPECT_NE(message.find("analysis.text.ppocr_detector_size"), std::string::npos) << message;
    EXPECT_NE(message.find("multiples of 32"), std::string::npos) << message;
  }
  const std::string message = config_error_of(
      [&] { parse_station_config(text("ppocr_box_threshold: 1.5"), "station.yaml"); });
  EXPECT_NE(message.find("analysis.text.ppocr_box_threshold"), std::string::npos) << message;
}

TEST(ConfigBadValue, StationLimitsHaveHardCaps) {
  const auto error_of = [](const std::string& line) {
    return config_error_of([&] { parse_station_config("limits:\n  " + line, "station.yaml"); });
  };
  const std::pair<const char*, const char*> cases[] = {
      {"max_width: 8193", "limits.max_width: must be between 1 and 8192"},
      {"max_height: 0", "limits.max_height: must be between 1 and 8192"},
      {"max_pixels: 33554433", "limits.max_pixels: must be between 1 and 33554432"},
      {"max_image_bytes: 67108865", "limits.max_image_bytes: must be between 1 and 67108864"},
      {"max_scans: 65", "limits.max_scans: must be between 1 and 64"},
      {"max_pixels_per_byte: .nan", "limits.max_pixels_per_byte: must be a finite number"},
      {"max_pixels_per_byte: 20000", "limits.max_pixels_per_byte: must be between 1 and 10000"},
      {"max_robots: 1025", "limits.max_robots: must be between 1 and 1024"},
      {"allowed_robots: [drone_0, ../etc]", "limits.allowed_robots: '../etc' is not a robot id"},
      {"allowed_robots: [a, b, c]\n  max_robots: 2",
       "limits.allowed_robots: 3 robots, more than limits.max_robots (2)"}};
  for (const auto& [line, expected] : cases) {
    const std::string message = error_of(line);
    EXPECT_NE(message.find(expected), std::string::npos) << line << ": " << message;
  }
}

TEST(ConfigRoundTrip, StationLimitsKeepTheirNewKeys) {
  StationConfig c;
  c.limits.max_pixels = 1000000;
  c.limits.max_scans = 3;
  c.limits.max_pixels_per_byte = 250.5;
  c.limits.allowed_robots = {"drone_0", "drone_1"};
  c.limits.max_robots = 5;
  const StationConfig back = parse_station_config(to_yaml(c), "round-trip");
  EXPECT_EQ(back.limits.max_pixels, 1000000u);
  EXPECT_EQ(back.limits.max_scans, 3);
  EXPECT_DOUBLE_EQ(back.limits.max_pixels_per_byte, 250.5);
  EXPECT_EQ(back.limits.allowed_robots, c.limits.allowed_robots);
  EXPECT_EQ(back.limits.max_robots, 5);
}

TEST(ConfigBadValue, MissionOptionalDomainIdIsRangeChecked) {
  const std::string message = config_error_of([] {
    parse_mission_config("domain_id: 300\nagent:\n  source:\n    max_frames: 5\n", "mission.yaml");
  });
  EXPECT_NE(message.find("mission.yaml:1: domain_id"), std::string::npos) << message;
  EXPECT_NE(message.find("must be between 0 and 232"), std::string::npos) << message;
}

TEST(ConfigBadValue, MissionDomainIdInRangeIsKept) {
  const MissionConfig parsed = parse_mission_config(
      "domain_id: 232\nagent:\n  source:\n    max_frames: 5\n", "mission.yaml");
  ASSERT_TRUE(parsed.domain_id.has_value());
  EXPECT_EQ(*parsed.domain_id, 232);
}

TEST(ConfigBadValue, InvalidYamlNamesOrigin) {
  const std::string message = agent_error("source: [unclosed\n");
  EXPECT_NE(message.find("agent.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("not valid YAML"), std::string::npos) << message;
}

TEST(ConfigCrossField, FolderSourceWithoutPathIsRejected) {
  const std::string message = agent_error("source:\n  kind: folder\n");
  EXPECT_NE(message.find("agent.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("source.path"), std::string::npos) << message;
}

TEST(ConfigCrossField, VideoSourceWithoutPathIsRejected) {
  const std::string message = agent_error("source:\n  kind: video\n  path: \"\"\n");
  EXPECT_NE(message.find("source.path"), std::string::npos) << message;
}

TEST(ConfigCrossField, FolderSourceWithPathNeedsNoMaxFrames) {
  const AgentConfig parsed =
      parse_agent_config("source:\n  kind: folder\n  path: /data/frames\n", "agent.yaml");
  EXPECT_EQ(parsed.source.kind, SourceConfig::Kind::kImageFolder);
  EXPECT_EQ(parsed.source.path, "/data/frames");
  EXPECT_EQ(parsed.source.max_frames, 0u);
}

TEST(ConfigCrossField, MissionPrefixThatMakesInvalidRobotIdsIsRejected) {
  const std::string message = config_error_of([] {
    parse_mission_config("robot_id_prefix: \"bad prefix \"\nagent:\n  source:\n    max_frames: 5\n",
                         "mission.yaml");
  });
  EXPECT_NE(message.find("robot_id_prefix"), std::string::npos) << message;
}

TEST(ConfigLoad, MissingAgentFileNamesThePath) {
  const std::string path = "/nonexistent-keyfleet-dir/agent-missing.yaml";
  const std::string message = config_error_of([&] { load_agent_config(path); });
  EXPECT_NE(message.find(path), std::string::npos) << message;
}

TEST(ConfigLoad, MissingStationAndMissionFilesNameThePath) {
  const std::string station = "/nonexistent-keyfleet-dir/station-missing.yaml";
  const std::string mission = "/nonexistent-keyfleet-dir/mission-missing.yaml";
  EXPECT_NE(config_error_of([&] { load_station_config(station); }).find(station),
            std::string::npos);
  EXPECT_NE(config_error_of([&] { load_mission_config(mission); }).find(mission),
            std::string::npos);
}

TEST(RobotId, AcceptsUpTo32AllowedCharacters) {
  EXPECT_TRUE(is_valid_robot_id("drone_0"));
  EXPECT_TRUE(is_valid_robot_id("A-z_9"));
  EXPECT_TRUE(is_valid_robot_id(std::string(32, 'a')));
  EXPECT_FALSE(is_valid_robot_id(""));
  EXPECT_FALSE(is_valid_robot_id(std::string(33, 'a')));
  EXPECT_FALSE(is_valid_robot_id("bad id!"));
  EXPECT_FALSE(is_valid_robot_id("drone/0"));
}

TEST(ConfigRoundTrip, AgentToYamlParsesBackToTheSameValues) {
  AgentConfig c;
  c.robot_id = "scout-7";
  c.source.kind = SourceConfig::Kind::kVideoFile;
  c.source.path = "/videos/flight 1.mp4";
  c.source.fps = 12.5;
  c.source.realtime = false;
  c.source.max_frames = 1234;
  c.source.width = 320;
  c.source.height = 200;
  c.source.seed = 18446744073709551557ULL;  // needs all 64 bits
  c.selector.trigger.stride = 7;
  c.selector.semantic.bfloat16 = false;
  c.selector.decode_reduce = 4;
  c.codec.jpeg_quality = 42;
  c.ledger.baseline_sample_every = 3;
  c.outbox.path = "box.sqlite";
  c.outbox.max_pending = 77;
  c.outbox.max_age_s = 0.1;
  c.outbox.resend_after_s = 0.75;
  c.outbox.resend_batch = 4;
  c.dds.domain_id = 42;
  c.dds.partition = "field-test";
  c.dds.transport = DdsSettings::Transport::kNetwork;
  c.dds.initial_peers = {"10.0.0.2", "10.0.0.3"};
  c.dds.heartbeat_period_s = 0.05;
  c.stats_period_s = 2.5;
  c.wait_for_station_s = 0;
  c.log_level = "debug";

  const std::string yaml = to_yaml(c);
  const AgentConfig back = parse_agent_config(yaml, "round-trip");
  EXPECT_EQ(back.robot_id, c.robot_id) << yaml;
  EXPECT_EQ(back.source.kind, c.source.kind) << yaml;
  EXPECT_EQ(back.source.path, c.source.path);
  EXPECT_DOUBLE_EQ(back.source.fps, c.source.fps);
  EXPECT_EQ(back.source.realtime, c.source.realtime);
  EXPECT_EQ(back.source.max_frames, c.source.max_frames);
  EXPECT_EQ(back.source.width, c.source.width);
  EXPECT_EQ(back.source.height, c.source.height);
  EXPECT_EQ(back.source.seed, c.source.seed);
  EXPECT_EQ(back.selector.trigger.stride, c.selector.trigger.stride);
  EXPECT_EQ(back.selector.semantic.bfloat16, c.selector.semantic.bfloat16);
  EXPECT_EQ(back.selector.decode_reduce, 4);
  EXPECT_EQ(back.codec.jpeg_quality, c.codec.jpeg_quality);
  EXPECT_EQ(back.ledger.baseline_sample_every, c.ledger.baseline_sample_every);
  EXPECT_EQ(back.outbox.path, c.outbox.path);
  EXPECT_EQ(back.outbox.max_pending, c.outbox.max_pending);
  EXPECT_DOUBLE_EQ(back.outbox.max_age_s, c.outbox.max_age_s);
  EXPECT_DOUBLE_EQ(back.outbox.resend_after_s, c.outbox.resend_after_s);
  EXPECT_EQ(back.outbox.resend_batch, c.outbox.resend_batch);
  EXPECT_EQ(back.dds.domain_id, c.dds.domain_id);
  EXPECT_EQ(back.dds.partition, c.dds.partition);
  EXPECT_EQ(back.dds.transport, c.dds.transport);
  EXPECT_EQ(back.dds.initial_peers, c.dds.initial_peers);
  EXPECT_DOUBLE_EQ(back.dds.heartbeat_period_s, c.dds.heartbeat_period_s);
  EXPECT_DOUBLE_EQ(back.stats_period_s, c.stats_period_s);
  EXPECT_DOUBLE_EQ(back.wait_for_station_s, c.wait_for_station_s);
  EXPECT_EQ(back.log_level, c.log_level);
}

TEST(ConfigRoundTrip, StationToYamlParsesBackToTheSameValues) {
  StationConfig c;
  c.limits.max_image_bytes = 123456;
  c.limits.max_width = 1920;
  c.limits.max_height = 1080;
  c.database = "db/keyframes.sqlite";
  c.mission_log = "log.pb";
  c.report_period_s = 0.5;
  c.log_level = "warn";
  c.dds.partition = "lab";
  c.dds.lease_duration_s = 9.5;
  c.analysis.workers = 2;
  c.analysis.text.enabled = false;
  c.analysis.places.verifier = VerifierKind::kRansacFundamental;
  c.analysis.places.min_inliers = 45;

  const std::string yaml = to_yaml(c);
  const StationConfig back = parse_station_config(yaml, "round-trip");
  EXPECT_EQ(back.analysis.workers, 2) << yaml;
  EXPECT_FALSE(back.analysis.text.enabled);
  EXPECT_EQ(back.analysis.places.verifier, VerifierKind::kRansacFundamental);
  EXPECT_EQ(back.analysis.places.min_inliers, 45);
  EXPECT_EQ(back.limits.max_image_bytes, c.limits.max_image_bytes) << yaml;
  EXPECT_EQ(back.limits.max_width, c.limits.max_width);
  EXPECT_EQ(back.limits.max_height, c.limits.max_height);
  EXPECT_EQ(back.database, c.database);
  EXPECT_EQ(back.mission_log, c.mission_log);
  EXPECT_DOUBLE_EQ(back.report_period_s, c.report_period_s);
  EXPECT_EQ(back.log_level, c.log_level);
  EXPECT_EQ(back.dds.partition, c.dds.partition);
  EXPECT_DOUBLE_EQ(back.dds.lease_duration_s, c.dds.lease_duration_s);
}

TEST(ConfigRoundTrip, MissionToYamlKeepsNestedAgentStationAndOptionalDomain) {
  MissionConfig c;
  c.name = "survey.north";
  c.drones = 5;
  c.robot_id_prefix = "uav-";
  c.run_root = "/tmp/runs";
  c.domain_id = 17;
  c.agent_timeout_s = 120;
  c.agent.source.max_frames = 300;
  c.agent.codec.jpeg_quality = 60;
  c.station.limits.max_width = 4096;

  const std::string yaml = to_yaml(c);
  const MissionConfig back = parse_mission_config(yaml, "round-trip");
  EXPECT_EQ(back.name, c.name) << yaml;
  EXPECT_EQ(back.drones, c.drones);
  EXPECT_EQ(back.robot_id_prefix, c.robot_id_prefix);
  EXPECT_EQ(back.run_root, c.run_root);
  EXPECT_EQ(back.domain_id, c.domain_id);
  EXPECT_DOUBLE_EQ(back.agent_timeout_s, c.agent_timeout_s);
  EXPECT_EQ(back.agent.source.max_frames, c.agent.source.max_frames);
  EXPECT_EQ(back.agent.codec.jpeg_quality, c.agent.codec.jpeg_quality);
  EXPECT_EQ(back.station.limits.max_width, c.station.limits.max_width);

  c.domain_id.reset();
  EXPECT_FALSE(parse_mission_config(to_yaml(c), "round-trip").domain_id.has_value());
}

std::filesystem::path configs_dir() {
  return std::filesystem::path(KEYFLEET_SOURCE_DIR) / "configs";
}

TEST(ShippedConfigs, AgentYamlLoads) {
  const AgentConfig c = load_agent_config((configs_dir() / "agent.yaml").string());
  EXPECT_TRUE(is_valid_robot_id(c.robot_id));
  EXPECT_GT(c.source.max_frames, 0u);
}

TEST(ShippedConfigs, StationYamlLoads) {
  const StationConfig c = load_station_config((configs_dir() / "station.yaml").string());
  EXPECT_GT(c.limits.max_image_bytes, 0u);
  // The shipped file states the defaults of config.hpp.
  const StationLimits defaults;
  EXPECT_EQ(c.limits.max_image_bytes, defaults.max_image_bytes);
  EXPECT_EQ(c.limits.max_width, defaults.max_width);
  EXPECT_EQ(c.limits.max_height, defaults.max_height);
  EXPECT_EQ(c.limits.max_pixels, defaults.max_pixels);
  EXPECT_EQ(c.limits.max_scans, defaults.max_scans);
  EXPECT_EQ(c.limits.max_pixels_per_byte, defaults.max_pixels_per_byte);
  EXPECT_EQ(c.limits.allowed_robots, defaults.allowed_robots);
  EXPECT_EQ(c.limits.max_robots, defaults.max_robots);
}

// configs/ naming: scenario_*.yaml are scenario files, eval*.yaml evaluations,
// experiment_bandwidth*.yaml bandwidth experiments, every other extra file a mission; the
// subfolders (the configs of one measurement) by the same names.
TEST(ShippedConfigs, EveryScenarioAndMissionFileInConfigsLoads) {
  int scenarios = 0, missions = 0, evaluations = 0, experiments = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(configs_dir())) {
    const auto name = entry.path().filename().string();
    if (entry.path().extension() != ".yaml" || name == "agent.yaml" || name == "station.yaml")
      continue;
    SCOPED_TRACE(entry.path().string());
    if (name.rfind("scenario_", 0) == 0) {
      EXPECT_NO_THROW(load_scenario_config(entry.path().string()));
      ++scenarios;
    } else if (name.rfind("eval", 0) == 0) {
      EXPECT_NO_THROW(load_eval_config(entry.path().string()));
      ++evaluations;
    } else if (name.rfind("experiment_bandwidth", 0) == 0) {
      EXPECT_NO_THROW(load_bandwidth_experiment_config(entry.path().string()));
      ++experiments;
    } else {
      EXPECT_NO_THROW(load_mission_config(entry.path().string()));
      ++missions;
    }
  }
  EXPECT_GT(scenarios, 0);
  EXPECT_GT(missions, 0);
  // eval.yaml (the demo's street), eval_side.yaml, eval_encodings.yaml (issue 30's encodings),
  // and semantic_candidates/'s six (selector.max_scored 0, 2, 3 on both street kinds)
  EXPECT_EQ(evaluations, 9);
  // experiment_bandwidth{,_radio,_adaptation,_words}.yaml
  EXPECT_EQ(experiments, 4);
}

}  // namespace
}  // namespace keyfleet
