// KeyframeStore: exactly-once storage, byte-identical blobs, totals, stats, durability.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

constexpr std::int64_t kT0 = 1'700'000'000'000'000'000LL;

AgentStats stats_for(const std::string& robot, std::int64_t report_time_ns,
                     std::uint64_t frames_seen) {
  AgentStats s;
  s.robot_id = robot;
  s.report_time_ns = report_time_ns;
  s.frames_seen = frames_seen;
  s.vslam_keyframes = frames_seen / 10;
  s.keyframes_sent = 4;
  s.keyframes_resent = 1;
  s.keyframes_dropped = 2;
  s.keyframes_pending = 3;
  s.bytes_sent = 4000;
  s.bytes_resent = 1000;
  s.stream_all_bytes = 123456789;
  s.stream_all_estimated = true;
  s.stream_all_sampled_frames = frames_seen / 10;
  s.vslam_keyframe_bytes = 55555;
  s.vslam_keyframe_estimated = false;
  s.stages = {{"encode", 12.5, frames_seen}};
  return s;
}

const RobotTotals* find_robot(const std::vector<RobotTotals>& totals, const std::string& id) {
  for (const auto& t : totals)
    if (t.robot_id == id) return &t;
  return nullptr;
}
// A pointer into a temporary would dangle: keep the totals in a variable.
const RobotTotals* find_robot(std::vector<RobotTotals>&&, const std::string&) = delete;

class KeyframeStoreTest : public ::testing::Test {
 protected:
  // The stored image of (robot, sequence), read back through a separate connection.
  std::vector<std::uint8_t> stored_image(const std::string& robot, std::uint64_t sequence) {
    SqliteDb db(path_, SqliteDb::Mode::kReadOnly);
    auto query = db.prepare("SELECT image FROM keyframes WHERE robot_id=? AND sequence_number=?");
    query.bind(1, robot).bind(2, static_cast<std::int64_t>(sequence));
    if (!query.step()) {
      ADD_FAILURE() << "no row for " << robot << " #" << sequence;
      return {};
    }
    return query.blob(0);
  }

  keyfleet::test::TempDir dir_;
  std::string path_ = dir_.file("station.sqlite");
};

// A keyframe without ORB keypoints (a blank image) has empty feature blobs: they must be stored
// as empty blobs, not NULL (a NOT NULL column refused the analysis, and the station retried it
// in a loop).
TEST(KeyframeStoreIntegrity, ADamagedDatabaseIsRefusedAtStartNamingTheFile) {
  test::TempDir dir;
  const std::string path = dir.file("station.sqlite");
  {
    KeyframeStore store(path);
    for (std::uint64_t s = 0; s < 40; ++s) {
      const Keyframe k = test::make_valid_keyframe("alpha", s, 160, 120);
      store.store(k, k.image.size(), 1000 + static_cast<std::int64_t>(s));
    }
  }
  { KeyframeStore reopened(path); }  // a sound file opens
  {
    // Scribble over the middle of the file (not the first page, which holds the schema).
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekg(0, std::ios::end);
    const auto size = static_cast<long>(file.tellg());
    ASSERT_GT(size, 3 * 4096);
    for (long at = 4096; at < size - 4096; at += 4096) {
      file.seekp(at);
      const std::string junk(64, '\xA5');
      file.write(junk.data(), static_cast<std::streamsize>(junk.size()));
    }
  }
  try {
    KeyframeStore damaged(path);
    FAIL() << "a damaged database opened";
  } catch (const SqliteError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("integrity check"), std::string::npos) << e.what();
  }
}

TEST(SqliteBlob, AnEmptyBlobIsStoredAsAnEmptyBlobNotNull) {
  test::TempDir dir;
  SqliteDb db(dir.file("blob.sqlite"));
  db.exec("CREATE TABLE t (b BLOB NOT NULL)");
  db.prepare("INSERT INTO t (b) VALUES (?)").bind(1, std::vector<std::uint8_t>{}).step();
  auto q = db.prepare("SELECT b IS NULL, length(b), b FROM t");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.int64(0), 0);
  EXPECT_EQ(q.int64(1), 0);
  EXPECT_TRUE(q.blob(2).empty());
}

TEST_F(KeyframeStoreTest, NewStoreIsEmpty) {
  const KeyframeStore store(path_);
  EXPECT_EQ(store.keyframe_count(), 0u);
  EXPECT_TRUE(store.totals().empty());
  EXPECT_EQ(store.path(), path_);
}

TEST_F(KeyframeStoreTest, StoresOnceThenReportsDuplicate) {
  KeyframeStore store(path_);
  const Keyframe k = keyfleet::test::make_valid_keyframe("drone_0", 7);
  EXPECT_EQ(store.store(k, 2000, kT0), StoreOutcome::kStored);
  EXPECT_EQ(store.store(k, 2000, kT0 + 1), StoreOutcome::kDuplicate);
  EXPECT_EQ(store.keyframe_count(), 1u);
}

TEST_F(KeyframeStoreTest, SameSequenceFromAnotherRobotIsNotADuplicate) {
  KeyframeStore store(path_);
  EXPECT_EQ(store.store(keyfleet::test::make_valid_keyframe("drone_0", 0), 100, kT0),
            StoreOutcome::kStored);
  EXPECT_EQ(store.store(keyfleet::test::make_valid_keyframe("drone_1", 0), 100, kT0),
            StoreOutcome::kStored);
  EXPECT_EQ(store.keyframe_count(), 2u);
}

TEST_F(KeyframeStoreTest, StoredImageIsByteIdentical) {
  KeyframeStore store(path_);
  Keyframe k = keyfleet::test::make_valid_keyframe("drone_0", 1);
  k.image = keyfleet::test::random_bytes(50000, 3);
  k.image[100] = 0;  // embedded NUL bytes must survive
  ASSERT_EQ(store.store(k, 51000, kT0), StoreOutcome::kStored);
  EXPECT_EQ(stored_image("drone_0", 1), k.image);
}

// The same sequence number with another image is a robot that lost its numbering, not a
// resend: the first copy stays where it is, the second is kept apart and counted.
TEST_F(KeyframeStoreTest, SameSequenceWithAnotherImageIsAConflictAndBothAreKept) {
  KeyframeStore store(path_);
  Keyframe first = keyfleet::test::make_valid_keyframe("drone_0", 1);
  ASSERT_EQ(store.store(first, 100, kT0), StoreOutcome::kStored);
  EXPECT_EQ(store.store(first, 100, kT0 + 1), StoreOutcome::kDuplicate);
  Keyframe second = first;
  second.image = keyfleet::test::random_bytes(300, 4);
  EXPECT_EQ(store.store(second, 300, kT0 + 5), StoreOutcome::kConflict);
  EXPECT_EQ(store.store(second, 300, kT0 + 6), StoreOutcome::kConflict);  // kept once
  EXPECT_EQ(stored_image("drone_0", 1), first.image);
  SqliteDb db(path_, SqliteDb::Mode::kReadOnly);
  auto kept = db.prepare(
      "SELECT image FROM conflicts WHERE robot_id='drone_0' AND "
      "sequence_number=1");
  ASSERT_TRUE(kept.step());
  EXPECT_EQ(kept.blob(0), second.image);
  EXPECT_FALSE(kept.step());
  const auto all = store.totals();
  const RobotTotals* totals = find_robot(all, "drone_0");
  ASSERT_NE(totals, nullptr);
  EXPECT_EQ(totals->keyframes, 1u);
  EXPECT_EQ(totals->conflicts, 1u);
}

TEST_F(KeyframeStoreTest, StoresMetadataAndPoseColumns) {
  KeyframeStore store(path_);
  const Keyframe k = keyfleet::test::make_valid_keyframe("drone_2", 9);
  ASSERT_EQ(store.store(k, 777, kT0 + 42), StoreOutcome::kStored);
  SqliteDb db(path_, SqliteDb::Mode::kReadOnly);
  auto q = db.prepare(
      "SELECT frame_index, capture_time_ns, received_ns, width, height, encoding, "
      "serialized_bytes, pose_tx, pose_qw FROM keyframes");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.int64(0), static_cast<std::int64_t>(k.frame_index));
  EXPECT_EQ(q.int64(1), k.capture_time_ns);
  EXPECT_EQ(q.int64(2), kT0 + 42);
  EXPECT_EQ(q.int64(3), 64);
  EXPECT_EQ(q.int64(4), 48);
  EXPECT_EQ(q.text(5), "jpeg");
  EXPECT_EQ(q.int64(6), 777);
  EXPECT_EQ(q.real(7), k.camera_pose->tx);
  EXPECT_EQ(q.real(8), k.camera_pose->qw);
}

TEST_F(KeyframeStoreTest, TotalsSumPerRobotIncludingRejections) {
  KeyframeStore store(path_);
  const Keyframe a0 = keyfleet::test::make_valid_keyframe("alpha", 0);
  const Keyframe a1 = keyfleet::test::make_valid_keyframe("alpha", 1, 80, 60);
  const Keyframe b0 = keyfleet::test::make_valid_keyframe("bravo", 0);
  store.store(a0, 1000, kT0 + 10);
  store.store(a1, 1500, kT0 + 70);
  store.store(a1, 1500, kT0 + 90);  // duplicate: not counted twice
  store.store(b0, 400, kT0 + 20);
  EXPECT_TRUE(store.record_rejection("bravo", 5, "corrupt", kT0 + 30));
  EXPECT_TRUE(store.record_rejection("charlie", 0, "corrupt", kT0 + 40));

  const auto totals = store.totals();
  ASSERT_EQ(totals.size(), 3u);
  const RobotTotals* alpha = find_robot(totals, "alpha");
  const RobotTotals* bravo = find_robot(totals, "bravo");
  const RobotTotals* charlie = find_robot(totals, "charlie");
  ASSERT_TRUE(alpha && bravo && charlie);

  EXPECT_EQ(alpha->keyframes, 2u);
  EXPECT_EQ(alpha->image_bytes, a0.image.size() + a1.image.size());
  EXPECT_EQ(alpha->serialized_bytes, 2500u);
  EXPECT_EQ(alpha->first_received_ns, kT0 + 10);
  EXPECT_EQ(alpha->last_received_ns, kT0 + 70);
  EXPECT_EQ(alpha->rejected, 0u);
  EXPECT_FALSE(alpha->latest_stats.has_value());

  EXPECT_EQ(bravo->keyframes, 1u);
  EXPECT_EQ(bravo->serialized_bytes, 400u);
  EXPECT_EQ(bravo->rejected, 1u);

  EXPECT_EQ(charlie->keyframes, 0u);
  EXPECT_EQ(charlie->rejected, 1u);
}

TEST_F(KeyframeStoreTest, RecordRejectionIsOncePerRobotAndSequence) {
  KeyframeStore store(path_);
  EXPECT_TRUE(store.record_rejection("drone_0", 3, "bad", kT0));
  EXPECT_FALSE(store.record_rejection("drone_0", 3, "bad again", kT0 + 1));
  EXPECT_TRUE(store.record_rejection("drone_0", 4, "bad", kT0));
  const auto totals = store.totals();
  ASSERT_EQ(totals.size(), 1u);
  EXPECT_EQ(totals[0].rejected, 2u);
}

TEST_F(KeyframeStoreTest, RecordStatsRoundTripsEveryCounter) {
  KeyframeStore store(path_);
  const AgentStats s = stats_for("drone_0", kT0, 300);
  store.record_stats(s);
  const auto totals = store.totals();
  ASSERT_EQ(totals.size(), 1u);
  ASSERT_TRUE(totals[0].latest_stats.has_value());
  const AgentStats& got = *totals[0].latest_stats;
  EXPECT_EQ(got.robot_id, "drone_0");
  EXPECT_EQ(got.report_time_ns, s.report_time_ns);
  EXPECT_EQ(got.finished, s.finished);
  EXPECT_EQ(got.frames_seen, s.frames_seen);
  EXPECT_EQ(got.vslam_keyframes, s.vslam_keyframes);
  EXPECT_EQ(got.keyframes_sent, s.keyframes_sent);
  EXPECT_EQ(got.keyframes_resent, s.keyframes_resent);
  EXPECT_EQ(got.keyframes_dropped, s.keyframes_dropped);
  EXPECT_EQ(got.keyframes_pending, s.keyframes_pending);
  EXPECT_EQ(got.bytes_sent, s.bytes_sent);
  EXPECT_EQ(got.bytes_resent, s.bytes_resent);
  EXPECT_EQ(got.stream_all_bytes, s.stream_all_bytes);
  EXPECT_EQ(got.stream_all_estimated, s.stream_all_estimated);
  EXPECT_EQ(got.stream_all_sampled_frames, s.stream_all_sampled_frames);
  EXPECT_EQ(got.vslam_keyframe_bytes, s.vslam_keyframe_bytes);
  EXPECT_EQ(got.vslam_keyframe_estimated, s.vslam_keyframe_estimated);
  ASSERT_EQ(got.stages.size(), 1u);
  EXPECT_EQ(got.stages[0].stage, "encode");
  EXPECT_EQ(got.stages[0].cpu_ms_total, 12.5);
  EXPECT_EQ(got.stages[0].calls, 300u);
}

TEST_F(KeyframeStoreTest, RecordStatsKeepsTheNewestReport) {
  KeyframeStore store(path_);
  store.record_stats(stats_for("drone_0", kT0 + 200, 20));
  store.record_stats(stats_for("drone_0", kT0 + 100, 10));  // arrives late: older
  auto totals = store.totals();
  ASSERT_EQ(totals.size(), 1u);
  ASSERT_TRUE(totals[0].latest_stats.has_value());
  EXPECT_EQ(totals[0].latest_stats->report_time_ns, kT0 + 200);
  EXPECT_EQ(totals[0].latest_stats->frames_seen, 20u);
  ASSERT_EQ(totals[0].latest_stats->stages.size(), 1u);
  EXPECT_EQ(totals[0].latest_stats->stages[0].calls, 20u);

  store.record_stats(stats_for("drone_0", kT0 + 300, 30));
  totals = store.totals();
  EXPECT_EQ(totals[0].latest_stats->report_time_ns, kT0 + 300);
  EXPECT_EQ(totals[0].latest_stats->frames_seen, 30u);
  EXPECT_EQ(totals[0].latest_stats->stages[0].calls, 30u);
}

TEST_F(KeyframeStoreTest, StatsHistoryKeepsEachNewerReportInTimeOrder) {
  KeyframeStore store(path_);
  store.record_stats(stats_for("drone_0", kT0 + 200, 20));
  store.record_stats(stats_for("drone_0", kT0 + 100, 10));  // older than the latest: not kept
  store.record_stats(stats_for("drone_0", kT0 + 300, 30));
  const auto history = KeyframeStore(path_, SqliteDb::Mode::kReadOnly).stats_history();
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0].report_time_ns, kT0 + 200);
  EXPECT_EQ(history[1].frames_seen, 30u);
  // A database written before the history was kept has none, read-only.
  {
    SqliteDb db(path_);
    db.exec("DROP TABLE agent_stats_history");
  }
  EXPECT_TRUE(KeyframeStore(path_, SqliteDb::Mode::kReadOnly).stats_history().empty());
}

TEST_F(KeyframeStoreTest, StatsOfDifferentRobotsAreKeptApart) {
  KeyframeStore store(path_);
  store.record_stats(stats_for("alpha", kT0 + 500, 50));
  store.record_stats(stats_for("bravo", kT0 + 100, 10));
  const auto totals = store.totals();
  ASSERT_EQ(totals.size(), 2u);
  EXPECT_EQ(find_robot(totals, "alpha")->latest_stats->frames_seen, 50u);
  EXPECT_EQ(find_robot(totals, "bravo")->latest_stats->frames_seen, 10u);
}

TEST_F(KeyframeStoreTest, ReopeningKeepsRowsAndStillDetectsDuplicates) {
  const Keyframe k = keyfleet::test::make_valid_keyframe("drone_0", 0);
  {
    KeyframeStore store(path_);
    ASSERT_EQ(store.store(k, 100, kT0), StoreOutcome::kStored);
    ASSERT_EQ(store.store(keyfleet::test::make_valid_keyframe("drone_0", 1), 100, kT0),
              StoreOutcome::kStored);
    store.record_rejection("drone_0", 2, "bad", kT0);
    store.record_stats(stats_for("drone_0", kT0, 10));
  }
  KeyframeStore reopened(path_);
  EXPECT_EQ(reopened.keyframe_count(), 2u);
  EXPECT_EQ(reopened.store(k, 100, kT0), StoreOutcome::kDuplicate);
  const auto totals = reopened.totals();
  ASSERT_EQ(totals.size(), 1u);
  EXPECT_EQ(totals[0].keyframes, 2u);
  EXPECT_EQ(totals[0].rejected, 1u);
  EXPECT_TRUE(totals[0].latest_stats.has_value());
  EXPECT_EQ(stored_image("drone_0", 0), k.image);
}

}  // namespace
}  // namespace keyfleet::station
