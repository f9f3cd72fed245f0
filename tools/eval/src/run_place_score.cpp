#include "keyfleet/eval/run_place_score.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/sqlite.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

using KeyframeId = std::pair<std::string, std::int64_t>;  // robot id, sequence number

}  // namespace

RunPlaceScore score_run_places(const std::string& scenario_dir, const std::string& station_db,
                               double tolerance_m) {
  const scenario::Scenario street = scenario::read_scenario(scenario_dir);
  std::map<std::string, std::vector<scenario::FrameTruth>> truth;  // by robot id
  for (const auto& drone : street.drones)
    truth[drone.robot_id] =
        scenario::read_frame_truth((fs::path(scenario_dir) / drone.folder).string());

  RunPlaceScore score;
  SqliteDb db(station_db, SqliteDb::Mode::kReadOnly);
  std::map<KeyframeId, double> position;  // where the keyframe's optical axis meets the street
  auto keyframes = db.prepare(
      "SELECT k.robot_id, k.sequence_number, k.frame_index, a.status FROM keyframes k LEFT JOIN "
      "keyframe_analysis a ON a.robot_id = k.robot_id AND a.sequence_number = "
      "k.sequence_number");
  while (keyframes.step()) {
    const auto drone = truth.find(keyframes.text(0));
    const auto frame = std::size_t(keyframes.int64(2));
    if (drone == truth.end() || frame >= drone->second.size()) continue;
    ++score.keyframes;
    if (!keyframes.is_null(3) && keyframes.text(3) == "done") ++score.analysed;
    position[{keyframes.text(0), keyframes.int64(1)}] = drone->second[frame].street_position_m;
  }

  std::set<KeyframeId> matched;
  auto matches = db.prepare(
      "SELECT robot_id, sequence_number, match_robot_id, match_sequence_number FROM "
      "place_matches WHERE robot_id <> match_robot_id");
  while (matches.step()) {
    const KeyframeId query{matches.text(0), matches.int64(1)};
    const KeyframeId found{matches.text(2), matches.int64(3)};
    ++score.matches;
    matched.insert(query);
    const auto a = position.find(query), b = position.find(found);
    if (a != position.end() && b != position.end() &&
        std::abs(a->second - b->second) <= tolerance_m)
      ++score.right;
  }
  score.matched_keyframes = matched.size();
  return score;
}

}  // namespace keyfleet::eval
