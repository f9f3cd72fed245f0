#pragma once
// What a run's station read, scored against the generated scenario it replayed: of the sign
// words fully visible in the keyframes it received, how many it read there, and how many of the
// words it reported are no word of the street at all (junk).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace keyfleet::eval {

struct RunTextScore {
  std::size_t keyframes = 0;       // received keyframes of robots the scenario knows
  std::size_t visible_words = 0;   // distinct sign words fully visible in some received keyframe
  std::size_t read_visible = 0;    // of those, read at their place in a keyframe that shows them
  std::size_t words_reported = 0;  // every word the station stored
  std::size_t junk = 0;            // of those, no word (nor part of one) of any sign of the street
  std::vector<std::string> read_words, missed_words, junk_words;  // distinct, sorted
  double read_rate() const {
    return visible_words ? double(read_visible) / double(visible_words) : 0;
  }
  double junk_rate() const { return words_reported ? double(junk) / double(words_reported) : 0; }
};

// `scenario_dir`: the generated scenario; `station_db`: the station's SQLite database (opened
// read-only). Robots are matched to the scenario's drones by robot id. Throws StartupError or
// std::runtime_error naming the file that cannot be read.
// `keep` (robot id, sequence number), when given, limits the score to the keyframes it keeps
// (e.g. those that arrived within a latency bound).
using KeyframeFilter = std::function<bool(const std::string& robot_id, std::int64_t sequence)>;
RunTextScore score_run_text(const std::string& scenario_dir, const std::string& station_db,
                            const KeyframeFilter& keep = {});

// The score as a few lines of text for a report.
std::string format_run_text_score(const RunTextScore& score);

}  // namespace keyfleet::eval
