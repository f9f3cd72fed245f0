// The station's analysis around the engines: the bounded pool and its overload policy, the
// analysis tables (words with FTS5, features, matches), the map they feed, and a restart.
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>

#include <atomic>
#include <condition_variable>
#include <csignal>
#include <cstdlib>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "keyfleet/common/image_codec.hpp"
#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/common/thread_name.hpp"
#include "keyfleet/station/analysis_attempts.hpp"
#include "keyfleet/station/analysis_exports.hpp"
#include "keyfleet/station/analysis_pool.hpp"
#include "keyfleet/station/analysis_setup.hpp"
#include "keyfleet/station/analysis_store.hpp"
#include "keyfleet/station/keyframe_analyzer.hpp"
#include "keyfleet/station/keyframe_store.hpp"
#include "keyfleet/station/station_analysis.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

using namespace std::chrono_literals;

AnalysisJob job_for(const std::string& robot, std::uint64_t sequence) {
  AnalysisJob job;
  job.key = {robot, sequence};
  job.capture_time_ns = static_cast<std::int64_t>(sequence) * 1'000'000'000;
  return job;
}

AnalysisResult done_result(const AnalysisJob& job) {
  AnalysisResult r;
  r.key = job.key;
  r.capture_time_ns = job.capture_time_ns;
  return r;
}

// A step that holds every job until released, to fill the queue on purpose.
class Gate {
 public:
  AnalysisResult pass(const AnalysisJob& job) {
    std::unique_lock lock(mutex_);
    ++entered_;
    changed_.notify_all();
    changed_.wait(lock, [&] { return open_; });
    return done_result(job);
  }
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  bool wait_entered(int count) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, 10s, [&] { return entered_ >= count; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  int entered_ = 0;
  bool open_ = false;
};

TEST(AnalysisExports, CsvCellsQuoteAndNeutraliseWhatASpreadsheetWouldEvaluate) {
  EXPECT_EQ(csv_cell("HOTEL"), "\"HOTEL\"");
  EXPECT_EQ(csv_cell("SAY \"HI\""), "\"SAY \"\"HI\"\"\"");
  for (const std::string formula : {"=HYPERLINK(\"x\")", "+1", "-1+2", "@SUM(A1)", "\tX", "\rX"})
    EXPECT_EQ(csv_cell(formula).substr(0, 2), "\"'") << formula;
  EXPECT_EQ(csv_cell("A=B"), "\"A=B\"") << "only a leading sign makes a formula";
  EXPECT_EQ(csv_cell(""), "\"\"");
}

TEST(AnalysisPool, DefersTheOldestWaitingJobsWhenFullAndLosesNone) {
  Gate gate;
  AnalysisPool pool({[&](const AnalysisJob& j) { return gate.pass(j); }}, 3, null_logger());
  pool.submit(job_for("r", 0));
  ASSERT_TRUE(gate.wait_entered(1));  // job 0 runs; 1..3 fill the queue; 4..6 push out 1..3
  for (std::uint64_t s = 1; s <= 6; ++s) pool.submit(job_for("r", s));
  gate.open();
  ASSERT_TRUE(pool.wait_until_idle(10s));

  std::map<std::uint64_t, AnalysisStatus> outcome;
  for (const AnalysisResult& r : pool.take_results()) {
    EXPECT_TRUE(outcome.emplace(r.key.sequence, r.status).second) << "two results for one job";
  }
  ASSERT_EQ(outcome.size(), 7u);
  for (std::uint64_t s : {0, 4, 5, 6}) EXPECT_EQ(outcome[s], AnalysisStatus::kDone) << s;
  for (std::uint64_t s : {1, 2, 3}) EXPECT_EQ(outcome[s], AnalysisStatus::kDeferred) << s;
  EXPECT_EQ(pool.counters().deferred, 3u);
}

// top -H and perf tell the station's analysis threads from Fast DDS's by their names.
TEST(AnalysisPool, NamesItsWorkerThreads) {
  std::mutex mutex;
  std::set<std::string> names;
  Gate gate;  // both workers hold a job before either finishes
  const auto step = [&](const AnalysisJob& j) {
    {
      std::lock_guard lock(mutex);
      names.insert(this_thread_name());
    }
    return gate.pass(j);
  };
  {
    AnalysisPool pool({step, step}, 4, null_logger());
    pool.submit(job_for("r", 0));
    pool.submit(job_for("r", 1));
    ASSERT_TRUE(gate.wait_entered(2));
    gate.open();
    ASSERT_TRUE(pool.wait_until_idle(10s));
  }
  EXPECT_EQ(names, (std::set<std::string>{"kf-analysis-0", "kf-analysis-1"}));
}

TEST(ThreadName, CarriesThePrefixAndKeepsWhatLinuxHolds) {
  std::string short_name, long_name;
  std::thread([&] {
    name_this_thread("http");
    short_name = this_thread_name();
    name_this_thread("a-role-longer-than-fifteen");
    long_name = this_thread_name();
  }).join();
  EXPECT_EQ(short_name, "kf-http");
  EXPECT_EQ(long_name, "kf-a-role-longe");
}

TEST(AnalysisPool, LatencyRunsFromSubmitToResultSoAQueueBehindOneWorkerShowsInIt) {
  // Each analysis takes at least 20 ms (the step's input, not a wait): with one worker and
  // three keyframes submitted at once, the second waits for the first and the third for both,
  // so their latencies are at least 20, 40 and 60 ms. Measured from the step's start they would
  // all be about 20.
  const auto analysis = [](const AnalysisJob& j) {
    const auto until = std::chrono::steady_clock::now() + 20ms;
    while (std::chrono::steady_clock::now() < until) {
    }
    return done_result(j);
  };
  AnalysisPool pool({analysis}, 8, null_logger());
  EXPECT_EQ(pool.latency().count, 0u);
  const auto submitted = std::chrono::steady_clock::now();
  for (std::uint64_t s = 0; s < 3; ++s) pool.submit(job_for("r", s));
  ASSERT_TRUE(pool.wait_until_idle(10s));
  const std::chrono::duration<double> whole = std::chrono::steady_clock::now() - submitted;

  const AnalysisPool::Latency lag = pool.latency();
  EXPECT_EQ(lag.count, 3u);
  EXPECT_GE(lag.p50_s, 0.040) << "the second keyframe waited for the first";
  EXPECT_GE(lag.max_s, 0.060);
  EXPECT_LE(lag.p50_s, lag.p95_s);
  EXPECT_LE(lag.p95_s, lag.max_s);
  EXPECT_LE(lag.max_s, whole.count() + 0.001);
}

TEST(AnalysisPool, ADeferredKeyframeHasNoLatencyUntilItIsAnalysed) {
  Gate gate;
  AnalysisPool pool({[&](const AnalysisJob& j) { return gate.pass(j); }}, 2, null_logger());
  pool.submit(job_for("r", 0));
  ASSERT_TRUE(gate.wait_entered(1));  // 0 runs; 1 and 2 wait; 3 pushes 1 out (deferred)
  for (std::uint64_t s = 1; s <= 3; ++s) pool.submit(job_for("r", s));
  gate.open();
  ASSERT_TRUE(pool.wait_until_idle(10s));
  EXPECT_EQ(pool.latency().count, 3u) << "0, 2 and 3 analysed; 1 deferred";
}

TEST(AnalysisPool, AThrowingStepMarksTheKeyframeFailedAndTheWorkerGoesOn) {
  AnalysisPool pool({[](const AnalysisJob& j) {
                      if (j.key.sequence == 1) throw std::runtime_error("engine crashed");
                      return done_result(j);
                    }},
                    8, null_logger());
  for (std::uint64_t s = 0; s < 3; ++s) pool.submit(job_for("r", s));
  ASSERT_TRUE(pool.wait_until_idle(10s));
  std::map<std::uint64_t, AnalysisResult> results;
  for (auto& r : pool.take_results()) results[r.key.sequence] = r;
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[1].status, AnalysisStatus::kFailed);
  EXPECT_NE(results[1].detail.find("engine crashed"), std::string::npos);
  EXPECT_EQ(results[2].status, AnalysisStatus::kDone);
}

class AnalysisStoreTest : public ::testing::Test {
 protected:
  void store_keyframe(const std::string& robot, std::uint64_t sequence) {
    Keyframe k = test::make_valid_keyframe(robot, sequence, 128, 96);
    k.capture_time_ns = static_cast<std::int64_t>(sequence) * 1'000'000'000;
    keyframes_.store(k, k.image.size() + 100, k.capture_time_ns + 5);
  }
  AnalysisResult result_with_words(const std::string& robot, std::uint64_t sequence,
                                   std::vector<std::string> words) {
    AnalysisResult r;
    r.key = {robot, sequence};
    r.capture_time_ns = static_cast<std::int64_t>(sequence) * 1'000'000'000;
    int x = 10;
    for (auto& w : words) {
      r.words.push_back(ReadWord{w, 0.9f, cv::Rect(x, 20, 50, 16)});
      x += 60;
    }
    return r;
  }

  test::TempDir dir_;
  JpegCodec codec_{90};
  KeyframeStore keyframes_{dir_.file("station.sqlite")};
  AnalysisStore store_{dir_.file("station.sqlite")};
};

TEST_F(AnalysisStoreTest, WordsAreSearchableWithRobotTimeKeyframeAndBox) {
  store_keyframe("drone_0", 3);
  store_keyframe("drone_1", 7);
  store_.save(result_with_words("drone_0", 3, {"HOTEL", "Bakery"}));
  store_.save(result_with_words("drone_1", 7, {"hotel"}));

  const auto hits = store_.search_words("HOTEL");
  ASSERT_EQ(hits.size(), 2u);  // FTS5's tokenizer folds case
  std::set<std::string> robots;
  for (const auto& w : hits) robots.insert(w.keyframe.robot_id);
  EXPECT_EQ(robots, (std::set<std::string>{"drone_0", "drone_1"}));
  const auto bakery = store_.search_words("bak*");
  ASSERT_EQ(bakery.size(), 1u);
  EXPECT_EQ(bakery[0].keyframe.sequence, 3u);
  EXPECT_EQ(bakery[0].capture_time_ns, 3'000'000'000);
  EXPECT_EQ(bakery[0].box, cv::Rect(70, 20, 50, 16));
  EXPECT_TRUE(store_.search_words("pharmacy").empty());
}

TEST_F(AnalysisStoreTest, AnalysingAgainReplacesTheWordsInsteadOfDuplicatingThem) {
  store_keyframe("drone_0", 1);
  store_.save(result_with_words("drone_0", 1, {"HOTEL"}));
  store_.save(result_with_words("drone_0", 1, {"HOTEL", "CAFE"}));
  EXPECT_EQ(store_.search_words("HOTEL").size(), 1u);
  EXPECT_EQ(store_.words().size(), 2u);
}

TEST_F(AnalysisStoreTest, UnanalysedListsNeverAnalysedAndDeferredKeyframesOldestFirst) {
  for (std::uint64_t s = 0; s < 4; ++s) store_keyframe("drone_0", s);
  store_.save(result_with_words("drone_0", 0, {}));
  AnalysisResult deferred;
  deferred.key = {"drone_0", 2};
  deferred.status = AnalysisStatus::kDeferred;
  store_.save(deferred);

  const auto pending = store_.unanalysed(10);
  ASSERT_EQ(pending.size(), 3u);
  EXPECT_EQ(pending[0].sequence, 1u);
  EXPECT_EQ(pending[1].sequence, 2u);
  EXPECT_EQ(pending[2].sequence, 3u);
  const auto without_in_flight = store_.unanalysed(10, {KeyframeKey{"drone_0", 1}});
  ASSERT_EQ(without_in_flight.size(), 2u);
  EXPECT_EQ(without_in_flight[0].sequence, 2u);

  const auto stored = keyframes_.load("drone_0", 3);
  ASSERT_TRUE(stored.has_value());
  EXPECT_FALSE(stored->image.empty());
  EXPECT_TRUE(codec_.decode(stored->image).ok());
  EXPECT_FALSE(keyframes_.load("drone_9", 0).has_value());
}

TEST_F(AnalysisStoreTest, FeaturesAndPlaceMatchesRoundTrip) {
  store_keyframe("drone_0", 1);
  store_keyframe("drone_1", 2);
  AnalysisResult r = result_with_words("drone_1", 2, {});
  OrbFeatures features;
  features.keypoints = {cv::KeyPoint(10.5f, 20.25f, 31.f, 45.f, 0.5f, 2),
                        cv::KeyPoint(100.f, 5.f, 44.6f, 90.f, 0.25f, 3)};
  features.descriptors = cv::Mat(2, 32, CV_8U);
  cv::randu(features.descriptors, 0, 256);
  r.features = features;
  r.place = PlaceMatch{{"drone_0", 1}, 0.31, 120, 64, 0.0};
  store_.save(r);

  const auto stored = store_.features();
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].key, (KeyframeKey{"drone_1", 2}));
  ASSERT_EQ(stored[0].features.keypoints.size(), 2u);
  EXPECT_FLOAT_EQ(stored[0].features.keypoints[0].pt.y, 20.25f);
  EXPECT_EQ(stored[0].features.keypoints[1].octave, 3);
  EXPECT_EQ(cv::norm(stored[0].features.descriptors, features.descriptors, cv::NORM_HAMMING), 0);
  const auto matches = store_.place_matches();
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].match, (KeyframeKey{"drone_0", 1}));
  EXPECT_EQ(matches[0].inliers, 64u);
}

// Test doubles for the engines: a reader that 'reads' the keyframe's robot-specific word,
// and a recogniser that matches every keyframe to the first one of another robot.
class ScriptedReader : public TextReader {
 public:
  std::vector<ReadWord> read(const cv::Mat& bgr) override {
    return {ReadWord{bgr.cols > 100 ? "HOTEL" : "CAFE", 0.8f, cv::Rect(1, 2, 30, 10)}};
  }
  std::string name() const override { return "scripted"; }
};

class FirstOfOtherRobot : public PlaceRecognizer {
 public:
  PlaceOutcome recognise(const PlaceView& view, const PlaceFilter& filter) const override {
    PlaceOutcome outcome;
    for (const KeyframeKey& key : retrieve(view, 1, filter)) {
      outcome.best = PlaceMatch{key, 0.5, 100, 60, 0.0};
      outcome.checked.push_back(*outcome.best);
    }
    return outcome;
  }
  std::vector<KeyframeKey> retrieve(const PlaceView&, std::size_t max_results,
                                    const PlaceFilter& filter) const override {
    std::lock_guard lock(mutex_);
    std::vector<KeyframeKey> keys;
    for (const auto& [key, time] : added_)
      if ((!filter || filter(key, time)) && keys.size() < max_results) keys.push_back(key);
    return keys;
  }
  void add(const KeyframeKey& key, std::int64_t time, const PlaceView& view) override {
    std::lock_guard lock(mutex_);
    added_.emplace_back(key, time);
    if (view.descriptor == std::vector<float>{0.6f, 0.8f}) ++described_;
  }
  std::size_t described() const {
    std::lock_guard lock(mutex_);
    return described_;
  }
  std::size_t size() const override {
    std::lock_guard lock(mutex_);
    return added_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<KeyframeKey, std::int64_t>> added_;
  std::size_t described_ = 0;  // views that came with ConstantDescriber's descriptor
};

class ConstantDescriber : public vision::PlaceDescriber {
 public:
  std::vector<float> describe(const cv::Mat&) override { return {0.6f, 0.8f}; }
  const vision::PlaceDescriberInfo& info() const override { return info_; }

 private:
  vision::PlaceDescriberInfo info_{{160, 120}, 1.0, {}, 2, "constant"};
};

// A job queued at once carries the pixels the station's check decoded and is not decoded again;
// one restored from the database (no pixels) decodes its JPEG, and says so when it cannot.
TEST(KeyframeAnalyzer, ReadsThePixelsTheCheckDecodedElseDecodesTheJpeg) {
  AnalysisConfig config;
  KeyframeAnalyzer analyzer(std::make_unique<ScriptedReader>(), nullptr, nullptr, config,
                            null_logger());
  const Keyframe k = test::make_valid_keyframe("a", 0, 128, 96);
  AnalysisJob job = station::job_for(k);
  ASSERT_TRUE(job.image.empty());
  AnalysisResult r = analyzer.analyse(job);
  ASSERT_EQ(r.status, AnalysisStatus::kDone) << r.detail;
  ASSERT_EQ(r.words.size(), 1u);
  EXPECT_EQ(r.words[0].text, "HOTEL");  // the 128-pixel-wide JPEG decoded

  job = station::job_for(k, cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 90, 90)));
  job.jpeg.assign(16, 0xFF);  // not read: the pixels are at hand
  r = analyzer.analyse(job);
  ASSERT_EQ(r.status, AnalysisStatus::kDone) << r.detail;
  ASSERT_EQ(r.words.size(), 1u);
  EXPECT_EQ(r.words[0].text, "CAFE");  // the given 64-pixel-wide image

  job.image = cv::Mat();
  r = analyzer.analyse(job);
  EXPECT_EQ(r.status, AnalysisStatus::kFailed);
  EXPECT_NE(r.detail.find("cannot decode"), std::string::npos) << r.detail;
}

TEST_F(AnalysisStoreTest, StationAnalysisFeedsTheMapAndARestartRestoresIt) {
  AnalysisConfig config;
  config.places.same_robot_exclusion_s = 1e6;  // only other robots count as revisits
  FirstOfOtherRobot places;
  {
    KeyframeAnalyzer analyzer(std::make_unique<ScriptedReader>(), &places,
                              std::make_unique<ConstantDescriber>(), config, null_logger());
    AnalysisPool pool({[&](const AnalysisJob& j) { return analyzer.analyse(j); }}, 16,
                      null_logger());
    TopoMap map;
    StationAnalysis analysis(keyframes_, store_, map, pool, null_logger());
    analysis.restore(&places);
    for (const auto& [robot, sequence] :
         std::vector<std::pair<std::string, std::uint64_t>>{{"a", 0}, {"a", 1}, {"b", 0}}) {
      Keyframe k = test::make_valid_keyframe(robot, sequence, 128, 96);
      keyframes_.store(k, k.image.size(), 1);
      analysis.on_stored(k);
    }
    ASSERT_TRUE(analysis.drain(20s));
    EXPECT_EQ(map.node_count(), 3u);
    EXPECT_EQ(map.edge_count(EdgeKind::kTemporal), 1u);
    EXPECT_EQ(map.cross_robot_match_count(), 1u);  // b#0 -> a#0
    EXPECT_EQ(analysis.summary().analysed, 3u);
    EXPECT_EQ(store_.search_words("HOTEL").size(), 3u);
  }
  // A new station process on the same database.
  FirstOfOtherRobot restarted_places;
  AnalysisPool pool({[](const AnalysisJob& j) { return done_result(j); }}, 16, null_logger());
  TopoMap map;
  StationAnalysis analysis(keyframes_, store_, map, pool, null_logger());
  analysis.restore(&restarted_places);
  EXPECT_EQ(map.node_count(), 3u);
  EXPECT_EQ(map.edge_count(EdgeKind::kTemporal), 1u);
  EXPECT_EQ(map.cross_robot_match_count(), 1u);
  EXPECT_EQ(map.nodes_with_word("hotel").size(), 3u);
  EXPECT_EQ(restarted_places.size(), 3u);       // the ORB features stored by the first run
  EXPECT_EQ(restarted_places.described(), 3u);  // and the place descriptors
}

// A station's analysis over the fixture's database whose engines only count their calls; it has
// restored (so it has a backlog to work through).
struct CountingAnalysis {
  CountingAnalysis(KeyframeStore& keyframes, AnalysisStore& store, std::atomic<int>& analysed)
      : pool({[&analysed](const AnalysisJob& j) {
               ++analysed;
               return done_result(j);
             }},
             2, null_logger()),
        analysis(keyframes, store, map, pool, null_logger()) {
    analysis.restore(nullptr);
  }
  TopoMap map;
  AnalysisPool pool;
  StationAnalysis analysis;
};

TEST_F(AnalysisStoreTest, DeferredKeyframesAreAnalysedOnceTheQueueEmpties) {
  for (std::uint64_t s = 0; s < 5; ++s) store_keyframe("drone_0", s);
  for (std::uint64_t s : {1, 3}) {
    AnalysisResult deferred;
    deferred.key = {"drone_0", s};
    deferred.status = AnalysisStatus::kDeferred;
    store_.save(deferred);
  }
  std::atomic<int> analysed{0};
  CountingAnalysis counting(keyframes_, store_, analysed);
  StationAnalysis& analysis = counting.analysis;
  ASSERT_TRUE(analysis.drain(20s));
  EXPECT_EQ(analysed.load(), 5);  // the deferred two and the three never analysed
  EXPECT_TRUE(store_.unanalysed(10).empty());
  EXPECT_EQ(store_.count_with_status(AnalysisStatus::kDone), 5u);
}

// Questions to a finished run (keyfleet query, map, locate) open the stores read-only: they add
// no schema to a file that is not a station's, and read a database written before text regions.
TEST(ReadOnlyStores, WriteNothingAndReadOlderDatabases) {
  test::TempDir dir;
  const std::string other = dir.file("other.sqlite");
  SqliteDb(other).exec("CREATE TABLE unrelated (x INTEGER)");
  {
    KeyframeStore keyframes(other, SqliteDb::Mode::kReadOnly);
    const AnalysisStore analysis(other, SqliteDb::Mode::kReadOnly);
    EXPECT_THROW(analysis.search_words("HOTEL"), SqliteError);
  }
  // Must outlive its statement: sqlite3_close fails, and leaks, while a statement is open.
  SqliteDb reader(other, SqliteDb::Mode::kReadOnly);
  auto tables = reader.prepare("SELECT group_concat(name) FROM sqlite_master WHERE type = 'table'");
  ASSERT_TRUE(tables.step());
  EXPECT_EQ(tables.text(0), "unrelated");
  EXPECT_THROW(KeyframeStore(dir.file("missing.sqlite"), SqliteDb::Mode::kReadOnly), SqliteError);

  const std::string old = dir.file("old.sqlite");
  Keyframe k = test::make_valid_keyframe("drone_0", 3, 128, 96);
  KeyframeStore(old).store(k, k.image.size(), 1);
  SqliteDb(old).exec("ALTER TABLE keyframes DROP COLUMN text_regions");
  const auto loaded = KeyframeStore(old, SqliteDb::Mode::kReadOnly).load("drone_0", 3);
  ASSERT_TRUE(loaded.has_value());
  EXPECT_EQ(loaded->image, k.image);
  EXPECT_TRUE(loaded->text_regions.empty());
}

TEST_F(AnalysisStoreTest, AnAnalysisThatCannotBeSavedIsNotRetriedInALoop) {
  for (const std::string robot : {"good", "bad"}) store_keyframe(robot, 0);
  {
    // A real SQLite failure on one keyframe's row, as a full disk or a broken row would give.
    SqliteDb db(dir_.file("station.sqlite"));
    db.exec(
        "CREATE TRIGGER refuse_bad BEFORE INSERT ON keyframe_analysis WHEN NEW.robot_id = 'bad' "
        "BEGIN SELECT RAISE(ABORT, 'refused by the test'); END");
  }
  std::atomic<int> analysed{0};
  CountingAnalysis counting(keyframes_, store_, analysed);
  StationAnalysis& analysis = counting.analysis;
  ASSERT_TRUE(analysis.drain(20s)) << "the unsaved analysis kept the backlog busy";
  EXPECT_EQ(analysed.load(), 2);
  // Not lost: still unanalysed in the database, for the next start.
  EXPECT_EQ(store_.unanalysed(10), (std::vector<KeyframeKey>{{"bad", 0}}));
}

// One start of a station whose engine crashes the process on robot "poison"'s keyframes: the
// worker records each start before running the engine, as the station does.
[[noreturn]] void run_station_with_a_crashing_engine(const std::string& database) {
  KeyframeStore keyframes(database);
  AnalysisStore store(database);
  AnalysisAttempts attempts(database);
  TopoMap map;
  AnalysisPool pool({[](const AnalysisJob& j) {
                      if (j.key.robot_id == "poison") std::abort();
                      return done_result(j);
                    }},
                    4, null_logger(), [&attempts](const KeyframeKey& k) { attempts.started(k); });
  StationAnalysis analysis(keyframes, store, map, pool, null_logger());
  analysis.skip_abandoned(attempts, 3);
  analysis.restore(nullptr);
  std::exit(analysis.drain(20s) ? 0 : 2);
}

TEST(AnalysisCrashGuard, AKeyframeWhoseAnalysisKillsTheStationIsSkippedAfterThreeStarts) {
  test::TempDir dir;
  const std::string database = dir.file("station.sqlite");
  {
    KeyframeStore keyframes(database);
    AnalysisStore create_tables(database);
    for (const std::string robot : {"poison", "good"}) {  // the poison is analysed first
      Keyframe k = test::make_valid_keyframe(robot, 0, 128, 96);
      keyframes.store(k, k.image.size(), robot == "poison" ? 1 : 2);
    }
  }
  for (int start = 1; start <= 3; ++start) {
    EXPECT_EXIT(run_station_with_a_crashing_engine(database), ::testing::KilledBySignal(SIGABRT),
                "")
        << "start " << start << " should have died in the engine";
  }
  EXPECT_EXIT(run_station_with_a_crashing_engine(database), ::testing::ExitedWithCode(0), "")
      << "the fourth start should skip the keyframe and finish";

  AnalysisStore store(database, SqliteDb::Mode::kReadOnly);
  EXPECT_EQ(store.count_with_status(AnalysisStatus::kDone), 1u);
  EXPECT_EQ(store.count_with_status(AnalysisStatus::kFailed), 1u);
  EXPECT_TRUE(store.unanalysed(10).empty());
  auto detail = SqliteDb(database, SqliteDb::Mode::kReadOnly)
                    .prepare("SELECT detail FROM keyframe_analysis WHERE robot_id = 'poison'");
  ASSERT_TRUE(detail.step());
  EXPECT_NE(detail.text(0).find("started 3 times"), std::string::npos) << detail.text(0);
  EXPECT_TRUE(KeyframeStore(database, SqliteDb::Mode::kReadOnly).load("poison", 0).has_value())
      << "the keyframe itself is kept";
}

// Where ppocr's fetched models are not installed (no npm registry), the station reads with its
// fallback engine, saying once why and which file; with no fallback, or a start-up error that
// is not about missing models, it refuses to start.
TEST(StationTextReader, FallsBackOnlyWhereTheEnginesModelsAreMissing) {
  std::ostringstream log;
  const Logger logger = std::make_shared<spdlog::logger>(
      "test", std::make_shared<spdlog::sinks::ostream_sink_mt>(log));
  TextReadingConfig config;
  config.engine = "ppocr";
  config.ppocr.models = "/nonexistent/ppocr";
  auto reader = make_station_text_reader(config, logger);
  ASSERT_NE(reader, nullptr);
  EXPECT_EQ(reader->name(), "tesseract");
  EXPECT_EQ(config.engine, "tesseract");  // the next worker's reader starts it directly
  EXPECT_NE(log.str().find("/nonexistent/ppocr/ppocr_det_640x480.onnx"), std::string::npos)
      << log.str();
  EXPECT_NE(log.str().find("reading with 'tesseract' instead"), std::string::npos) << log.str();

  config.engine = "ppocr";
  config.fallback_engine = "";
  EXPECT_THROW(make_station_text_reader(config, logger), StartupError);
  config.fallback_engine = "tesseract";
  config.ppocr.detector_size = "650x480";  // refused for itself, not for a missing file
  try {
    make_station_text_reader(config, logger);
    ADD_FAILURE() << "a bad detector size was read past";
  } catch (const StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("650x480"), std::string::npos) << e.what();
  }
  config.enabled = false;
  EXPECT_EQ(make_station_text_reader(config, logger), nullptr);
}

}  // namespace
}  // namespace keyfleet::station
