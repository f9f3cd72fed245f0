// A mission's place matches judged against its generated street (eval::score_run_places): a
// station database written by hand over a tiny generated street with known street positions.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/eval/run_place_score.hpp"
#include "keyfleet/eval/run_text_score.hpp"
#include "keyfleet/scenario/scenario_generator.hpp"
#include "keyfleet/station/station_schema.hpp"
#include "test_support.hpp"

namespace keyfleet::eval {
namespace {

void add_keyframe(SqliteDb& db, const std::string& robot, int sequence, std::uint64_t frame,
                  bool analysed) {
  db.exec(
      "INSERT INTO keyframes (robot_id, sequence_number, frame_index, capture_time_ns, "
      "received_ns, vslam_keyframe_index, window_first_frame, window_last_frame, "
      "quality_score, sharpness_score, semantic_score, encoding, width, height, image, "
      "image_fnv1a64, serialized_bytes) VALUES ('" +
      robot + "', " + std::to_string(sequence) + ", " + std::to_string(frame) +
      ", 0, 0, 0, 0, 0, 0, 0, 0, 'jpeg', 160, 120, x'00', 0, 1)");
  if (analysed)
    db.exec(
        "INSERT INTO keyframe_analysis (robot_id, sequence_number, capture_time_ns, status, "
        "detail, analysed_order, words, candidates_checked, text_ms, places_ms) VALUES ('" +
        robot + "', " + std::to_string(sequence) + ", 0, 'done', '', 0, 0, 0, 0, 0)");
}

void add_match(SqliteDb& db, const std::string& robot, int sequence, const std::string& other,
               int other_sequence) {
  db.exec("INSERT INTO place_matches VALUES ('" + robot + "', " + std::to_string(sequence) + ", '" +
          other + "', " + std::to_string(other_sequence) + ", 50, 30, 0.5)");
}

TEST(RunPlaceScore, MatchesBetweenRobotsAreRightWithinTheToleranceOnTheStreet) {
  test::TempDir dir;
  ScenarioConfig config;
  config.seed = 4;
  config.frames_per_drone = 30;
  config.fps = 3;  // 10 s of flight at 2 m/s: 20 m of street
  config.width = 160;
  config.height = 120;
  config.street.length_m = 40;
  config.drones.count = 2;
  config.drones.days = 2;
  const std::string street = dir.file("street");
  scenario::generate_scenario(config, street, null_logger());
  const auto s = scenario::read_scenario(street);
  ASSERT_EQ(s.drones.size(), 2u);
  const std::string a = s.drones[0].robot_id, b = s.drones[1].robot_id;
  const auto truth_a = scenario::read_frame_truth(dir.file("street/" + s.drones[0].folder));
  const auto truth_b = scenario::read_frame_truth(dir.file("street/" + s.drones[1].folder));

  // For a's first frame: b's frame nearest on the street (right) and the farthest (wrong).
  std::size_t near = 0, far = 0;
  const double at = truth_a[0].street_position_m;
  for (std::size_t i = 0; i < truth_b.size(); ++i) {
    const double d = std::abs(truth_b[i].street_position_m - at);
    if (d < std::abs(truth_b[near].street_position_m - at)) near = i;
    if (d > std::abs(truth_b[far].street_position_m - at)) far = i;
  }
  ASSERT_LE(std::abs(truth_b[near].street_position_m - at), 5.0);
  ASSERT_GT(std::abs(truth_b[far].street_position_m - at), 5.0) << "street too short to test";

  const std::string db_path = dir.file("station.sqlite");
  {
    SqliteDb db(db_path, SqliteDb::Mode::kReadWrite);
    station::open_station_schema(db, SqliteDb::Mode::kReadWrite);
    add_keyframe(db, a, 0, 0, true);
    add_keyframe(db, b, 0, near, true);
    add_keyframe(db, b, 1, far, false);
    add_keyframe(db, "stranger", 0, 0, true);  // no drone of the street: not counted
    add_match(db, a, 0, b, 0);                 // right
    add_match(db, a, 0, b, 1);                 // wrong: far apart
    add_match(db, b, 1, b, 0);                 // one robot with itself: not between robots
    add_match(db, "stranger", 0, a, 0);        // unknown keyframe: counted, never right
    for (const auto& [robot, sequence] : {std::pair<std::string, int>{a, 0}, {b, 0}})
      db.exec(
          "INSERT INTO words (robot_id, sequence_number, text, confidence, x, y, width, "
          "height) VALUES ('" +
          robot + "', " + std::to_string(sequence) + ", 'ZZQX', 0.9, 1, 1, 10, 10)");
  }
  const RunPlaceScore score = score_run_places(street, db_path);
  EXPECT_EQ(score.keyframes, 3u);
  EXPECT_EQ(score.analysed, 2u);
  EXPECT_EQ(score.matches, 3u);
  EXPECT_EQ(score.right, 1u);
  EXPECT_EQ(score.matched_keyframes, 2u);  // a/0 and the stranger's
  EXPECT_NEAR(score.precision(), 1.0 / 3.0, 1e-12);

  // The text score over the same keyframes, and over those a filter keeps (e.g. in time): the
  // keyframes and the words the station stored in them.
  const auto all = score_run_text(street, db_path);
  EXPECT_EQ(all.keyframes, 3u);
  EXPECT_EQ(all.words_reported, 2u);
  EXPECT_EQ(all.junk, 2u);  // no word of the street
  const auto only_a = score_run_text(
      street, db_path, [&](const std::string& robot, std::int64_t) { return robot == a; });
  EXPECT_EQ(only_a.keyframes, 1u);
  EXPECT_EQ(only_a.words_reported, 1u);
  const auto none =
      score_run_text(street, db_path, [](const std::string&, std::int64_t) { return false; });
  EXPECT_EQ(none.keyframes, 0u);
  EXPECT_EQ(none.words_reported, 0u);
  EXPECT_EQ(none.read_visible, 0u);
}

TEST(RunPlaceScore, MissingDatabaseOrScenarioIsAnErrorNamingIt) {
  test::TempDir dir;
  try {
    score_run_places(dir.file("no-street"), dir.file("no.sqlite"));
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("no-street"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace keyfleet::eval
