#pragma once
// A mission's place matches judged against its generated street: each cross-robot match the
// station stored is right when the two keyframes look at street points within a tolerance
// (the same criterion as `keyfleet places eval`).
#include <cstddef>
#include <string>

namespace keyfleet::eval {

struct RunPlaceScore {
  std::size_t keyframes = 0;          // received keyframes of robots the scenario knows
  std::size_t analysed = 0;           // of those, analysed by the station (status done)
  std::size_t matches = 0;            // stored place matches between two robots
  std::size_t right = 0;              // of those, within the tolerance on the street
  std::size_t matched_keyframes = 0;  // keyframes with at least one cross-robot match
  double precision() const { return matches ? double(right) / double(matches) : 0.0; }
};

// `scenario_dir`: the generated scenario; `station_db`: the station's database (read-only).
// Matches of robots or frames the scenario does not know are counted and never right. Throws
// StartupError or std::runtime_error naming the file that cannot be read.
RunPlaceScore score_run_places(const std::string& scenario_dir, const std::string& station_db,
                               double tolerance_m = 5.0);

}  // namespace keyfleet::eval
