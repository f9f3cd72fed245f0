// Text regions from the robot (Keyframe::text_regions): taken from a text mask, carried through
// the wire conversion (and counted in the serialized size), the agent's outbox and the station's
// store (old databases migrated), checked on receipt (a lying hint never costs the image), and
// handed by the analysis to the reader.
#include <gtest/gtest.h>

#include <spdlog/sinks/ostream_sink.h>

#include <opencv2/imgproc.hpp>

#include <sstream>

#include "dds_wire_conversion.hpp"
#include "fake_links.hpp"
#include "keyfleet.h"
#include "keyfleet/agent/agent_config.hpp"
#include "keyfleet/agent/outbox.hpp"
#include "keyfleet/agent/text_regions.hpp"
#include "keyfleet/common/config_error.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/text_region_blob.hpp"
#include "keyfleet/station/ground_station.hpp"
#include "keyfleet/station/keyframe_analyzer.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/keyframe_validator.hpp"
#include "keyfleet/station/mission_log.hpp"
#include "keyfleet/station/station_config.hpp"
#include "keyfleetPubSubTypes.h"
#include "test_support.hpp"

namespace keyfleet {
namespace {

using Regions = std::vector<TextRegion>;

}  // namespace

// For gtest's messages.
void PrintTo(const TextRegion& r, std::ostream* out) {
  *out << "{" << r.x << ", " << r.y << ", " << r.w << ", " << r.h << "}";
}

namespace {

Regions some_regions() { return {{10, 20, 300, 40}, {0, 0, 1, 1}, {639, 479, 1, 1}, {5, 6, 7, 8}}; }

// ---------------------------------------------------------------- from the mask (agent)

TEST(TextRegionsFromMask, ComponentsScaledMergedAlongLinesSmallDroppedLargestFirst) {
  // A 320 x 240 mask of a 640 x 480 frame: two words on one line 6 px apart, one word below,
  // one speck.
  cv::Mat mask = cv::Mat::zeros(240, 320, CV_8U);
  mask(cv::Rect(20, 30, 40, 12)).setTo(255);
  mask(cv::Rect(66, 31, 30, 11)).setTo(255);
  mask(cv::Rect(100, 150, 50, 20)).setTo(255);
  mask(cv::Rect(300, 10, 2, 2)).setTo(255);
  const Regions regions = agent::text_regions(mask, {640, 480}, TextRegionsConfig{});
  ASSERT_EQ(regions.size(), 2u);
  EXPECT_EQ(regions[0], (TextRegion{200, 300, 100, 40}));  // the word below, larger
  EXPECT_EQ(regions[1], (TextRegion{40, 60, 152, 24}));    // the line, merged
}

TEST(TextRegionsFromMask, CappedDisabledOrNothingGivesAtMostTheCap) {
  cv::Mat mask = cv::Mat::zeros(100, 100, CV_8U);
  for (int i = 0; i < 10; ++i) mask(cv::Rect(5, 5 + 9 * i, 10 + i, 4)).setTo(255);
  TextRegionsConfig config;
  config.min_area_px = 0;
  config.max_regions = 3;
  const Regions regions = agent::text_regions(mask, {100, 100}, config);
  ASSERT_EQ(regions.size(), 3u);
  EXPECT_EQ(regions[0].w, 19);  // the largest ones
  config.enabled = false;
  EXPECT_TRUE(agent::text_regions(mask, {100, 100}, config).empty());
  EXPECT_TRUE(agent::text_regions(cv::Mat(), {100, 100}, TextRegionsConfig{}).empty());
  EXPECT_TRUE(agent::text_regions(cv::Mat::zeros(10, 10, CV_8U), {100, 100}, {}).empty());
}

TEST(TextRegionsFromMask, ThirtyTwoRegionsAreAFewHundredBytesOnTheWire) {
  // The sample's serialized size is what the agent counts as bytes sent (dds_links.cpp).
  Keyframe k = test::make_valid_keyframe("drone_0", 0);
  wire::Keyframe sample;
  wire::KeyframePubSubType type;
  dds::to_wire(k, sample);
  const auto without = type.getSerializedSizeProvider(&sample)();
  k.text_regions.assign(32, TextRegion{1, 2, 3, 4});
  dds::to_wire(k, sample);
  const auto with = type.getSerializedSizeProvider(&sample)();
  EXPECT_GE(with - without, 32u * 8u);
  EXPECT_LE(with - without, 32u * 8u + 8u);
}

TEST(TextRegionsConfig, LoadedFromYamlAndCheckedWhereTheyAre) {
  const AgentConfig agent = parse_agent_config(
      "selector:\n  text_regions: {enabled: false, max_regions: 8, min_area_px: 10}\n", "a.yaml");
  EXPECT_FALSE(agent.selector.text_regions.enabled);
  EXPECT_EQ(agent.selector.text_regions.max_regions, 8);
  EXPECT_EQ(agent.selector.text_regions.min_area_px, 10);
  EXPECT_THROW(parse_agent_config("selector:\n  text_regions: {merge_gap: .nan}\n", "a.yaml"),
               ConfigError);
  const StationConfig station = parse_station_config(
      "limits: {max_text_regions: 5}\nanalysis:\n  text: {region_hints: only, "
      "region_hint_detector_size: 320x256}\n",
      "s.yaml");
  EXPECT_EQ(station.limits.max_text_regions, 5);
  EXPECT_EQ(station.analysis.text.ppocr.region_hints, "only");
  EXPECT_EQ(station.analysis.text.ppocr.region_hint_detector_size, "320x256");
  try {
    parse_station_config("analysis:\n  text: {region_hints: sometimes}\n", "s.yaml");
    ADD_FAILURE() << "accepted region_hints: sometimes";
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("analysis.text.region_hints: must be one of first|off|only"),
        std::string::npos)
        << e.what();
  }
}

// ---------------------------------------------------------------- round trips

TEST(TextRegionsRoundTrip, ThroughTheWireConversion) {
  Keyframe k = test::make_valid_keyframe("drone_0", 3);
  k.text_regions = some_regions();
  k.text_regions.push_back({65535, 65535, 65535, 65535});
  wire::Keyframe sample;
  dds::to_wire(k, sample);
  EXPECT_EQ(dds::from_wire(std::move(sample)).text_regions, k.text_regions);
  k.text_regions.clear();
  dds::to_wire(k, sample);  // a reused sample loses the previous regions
  EXPECT_TRUE(dds::from_wire(std::move(sample)).text_regions.empty());
}

TEST(TextRegionsRoundTrip, ThroughTheBlob) {
  const Regions regions = some_regions();
  EXPECT_EQ(text_regions_blob(regions).size(), 8 * regions.size());
  EXPECT_EQ(text_regions_from_blob(text_regions_blob(regions)), regions);
  auto blob = text_regions_blob(regions);
  blob.resize(blob.size() - 3);  // a torn blob keeps its whole regions
  EXPECT_EQ(text_regions_from_blob(blob).size(), regions.size() - 1);
}

TEST(TextRegionsRoundTrip, ThroughTheOutboxAcrossARestart) {
  test::TempDir dir;
  const std::string path = dir.file("outbox.sqlite");
  {
    agent::Outbox outbox(path, "drone_0", OutboxConfig{});
    Keyframe a = test::make_valid_keyframe("drone_0", 0),
             b = test::make_valid_keyframe("drone_0", 1);
    a.text_regions = some_regions();
    outbox.add(a, 0);
    outbox.add(b, 0);
  }
  agent::Outbox reopened(path, "drone_0", OutboxConfig{});
  const auto due = reopened.due_for_resend(1, 10);
  ASSERT_EQ(due.size(), 2u);
  EXPECT_EQ(due[0].text_regions, some_regions());
  EXPECT_TRUE(due[1].text_regions.empty());
}

TEST(TextRegionsRoundTrip, OutboxOfAnOlderBuildIsMigrated) {
  test::TempDir dir;
  const std::string path = dir.file("outbox.sqlite");
  {
    SqliteDb db(path);  // the pending table as it was before text regions
    db.exec(
        "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);"
        "CREATE TABLE pending (sequence_number INTEGER PRIMARY KEY, created_ns INTEGER NOT NULL,"
        " last_sent_ns INTEGER, sends INTEGER NOT NULL DEFAULT 0, frame_index INTEGER NOT NULL,"
        " capture_time_ns INTEGER NOT NULL, vslam_keyframe_index INTEGER NOT NULL,"
        " window_first_frame INTEGER NOT NULL, window_last_frame INTEGER NOT NULL,"
        " quality_score REAL NOT NULL, sharpness_score REAL NOT NULL, semantic_score REAL NOT NULL,"
        " encoding TEXT NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,"
        " image BLOB NOT NULL, pose BLOB);"
        "INSERT INTO meta VALUES('robot_id', 'drone_0'), ('next_sequence', '1');"
        "INSERT INTO pending VALUES(0, 0, NULL, 0, 1, 2, 3, 4, 5, 0.5, 0.5, 0.5, 'jpeg', 64, 48,"
        " x'FFD8FFD9', NULL);");
  }
  agent::Outbox outbox(path, "drone_0", OutboxConfig{});
  ASSERT_EQ(outbox.due_for_resend(1, 10).size(), 1u);  // the old keyframe, without regions
  EXPECT_TRUE(outbox.due_for_resend(1, 10)[0].text_regions.empty());
  Keyframe k = test::make_valid_keyframe("drone_0", 1);
  k.text_regions = some_regions();
  outbox.add(k, 0);
  EXPECT_EQ(outbox.due_for_resend(1, 10).at(1).text_regions, some_regions());
}

TEST(TextRegionsRoundTrip, ThroughTheStationStoreAndAnOlderDatabaseIsMigrated) {
  test::TempDir dir;
  const std::string path = dir.file("station.sqlite");
  { station::KeyframeStore created(path); }
  {
    // As a database written before text regions, and before schema versions: without the
    // column, user_version 0.
    SqliteDb db(path);
    db.exec("ALTER TABLE keyframes DROP COLUMN text_regions");
    db.exec("PRAGMA user_version = 0");
  }
  station::KeyframeStore store(path);
  Keyframe k = test::make_valid_keyframe("drone_0", 1);
  k.text_regions = some_regions();
  ASSERT_EQ(store.store(k, 100, 5), station::StoreOutcome::kStored);
  ASSERT_EQ(store.store(test::make_valid_keyframe("drone_0", 2), 100, 6),
            station::StoreOutcome::kStored);
  EXPECT_EQ(store.load("drone_0", 1)->text_regions, some_regions());
  EXPECT_TRUE(store.load("drone_0", 2)->text_regions.empty());
}

// ---------------------------------------------------------------- the station's check

TEST(TextRegionReview, LyingRegionsAreDroppedClampedAndCapped) {
  const Regions lies = {
      {10, 10, 50, 20},          // fine
      {700, 10, 50, 20},         // starts right of a 640-wide image
      {10, 480, 50, 20},         // starts below it
      {65535, 65535, 10, 10},    // a negative position as it arrives in 16 bits
      {0, 0, 0, 20},             // empty
      {600, 400, 60000, 60000},  // absurd size: cut at the edge
      {0, 0, 65535, 65535},      // the whole image and more
  };
  const auto review = station::review_text_regions(lies, 640, 480, 64);
  EXPECT_EQ(review.regions, (Regions{{10, 10, 50, 20}, {600, 400, 40, 80}, {0, 0, 640, 480}}));
  EXPECT_EQ(review.dropped, 4u);
  EXPECT_EQ(review.clamped, 2u);
  EXPECT_EQ(review.over_limit, 0u);
  EXPECT_TRUE(review.changed());
  EXPECT_NE(review.summary().find("4 dropped"), std::string::npos) << review.summary();

  const Regions many(100000, TextRegion{1, 1, 2, 2});
  const auto capped = station::review_text_regions(many, 640, 480, 64);
  EXPECT_EQ(capped.regions.size(), 64u);
  EXPECT_EQ(capped.over_limit, 100000u - 64u);

  const auto fine = station::review_text_regions(some_regions(), 640, 480, 64);
  EXPECT_FALSE(fine.changed());
  EXPECT_EQ(fine.regions, some_regions());
}

class LyingHintsAtTheStation : public ::testing::Test {
 protected:
  test::TempDir dir_;
  StationLimits limits_;
  station::KeyframeStore store_{dir_.file("station.sqlite")};
  station::MissionLog log_{dir_.file("mission_log.pb")};
  test::FakeStationLink link_;
};

TEST_F(LyingHintsAtTheStation, KeyframeIsStoredWithItsRegionsFixedAndTheRobotWarnedOnce) {
  std::ostringstream printed;
  auto logger = std::make_shared<spdlog::logger>(
      "test", std::make_shared<spdlog::sinks::ostream_sink_mt>(printed));
  station::GroundStation station(limits_, store_, log_, link_, logger);
  std::vector<Keyframe> stored;
  station.on_stored([&](const Keyframe& k, const cv::Mat&) { stored.push_back(k); });
  for (std::uint64_t seq = 0; seq < 3; ++seq) {
    Keyframe k = test::make_valid_keyframe("liar", seq);  // 64 x 48
    k.text_regions = {{60, 40, 100, 100}, {64, 0, 5, 5}, {1, 2, 3, 4}};
    const KeyframeAck ack = station.handle({k, 1000, {}}, 1);
    EXPECT_EQ(ack.status, AckStatus::kStored) << ack.reason;
  }
  ASSERT_EQ(stored.size(), 3u);
  const Regions fixed = {{60, 40, 4, 8}, {1, 2, 3, 4}};
  EXPECT_EQ(stored[0].text_regions, fixed);
  EXPECT_EQ(store_.load("liar", 2)->text_regions, fixed);
  const std::string text = printed.str();
  const auto first = text.find("text regions");
  ASSERT_NE(first, std::string::npos) << text;
  EXPECT_EQ(text.find("text regions", first + 1), std::string::npos) << text;
  EXPECT_NE(text.find("1 dropped"), std::string::npos) << text;
}

// ---------------------------------------------------------------- reading with hints

// Records what it was asked; reads nothing.
class RecordingReader final : public station::TextReader {
 public:
  std::vector<station::ReadWord> read(const cv::Mat&) override {
    ++whole_reads;
    return {};
  }
  std::string name() const override { return "recording"; }
  int whole_reads = 0;
};

class HintRecordingReader final : public station::TextReader {
 public:
  explicit HintRecordingReader(std::vector<std::vector<cv::Rect>>* hints) : hints_(hints) {}
  std::vector<station::ReadWord> read(const cv::Mat&) override { return {}; }
  std::vector<station::ReadWord> read_with_hints(const cv::Mat&,
                                                 const std::vector<cv::Rect>& hints) override {
    hints_->push_back(hints);
    return {};
  }
  std::string name() const override { return "hints"; }

 private:
  std::vector<std::vector<cv::Rect>>* hints_;
};

TEST(ReadingWithHints, AReaderThatCannotUseThemReadsTheWholeImage) {
  RecordingReader reader;
  station::TextReader& seam = reader;
  seam.read_with_hints(cv::Mat(48, 64, CV_8UC3), {cv::Rect(1, 2, 3, 4)});
  EXPECT_EQ(reader.whole_reads, 1);
}

TEST(ReadingWithHints, TheAnalysisHandsTheStoredRegionsToTheReader) {
  std::vector<std::vector<cv::Rect>> hints;
  AnalysisConfig config;
  config.places.enabled = false;
  station::KeyframeAnalyzer analyzer(std::make_unique<HintRecordingReader>(&hints), nullptr,
                                     nullptr, config, null_logger());
  Keyframe k = test::make_valid_keyframe("drone_0", 0);
  k.text_regions = {{1, 2, 30, 4}, {5, 6, 7, 8}};
  const auto result = analyzer.analyse(station::job_for(k));
  EXPECT_EQ(result.status, station::AnalysisStatus::kDone);
  ASSERT_EQ(hints.size(), 1u);
  EXPECT_EQ(hints[0], (std::vector<cv::Rect>{{1, 2, 30, 4}, {5, 6, 7, 8}}));
}

}  // namespace
}  // namespace keyfleet
