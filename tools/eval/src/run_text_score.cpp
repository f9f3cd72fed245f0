#include "keyfleet/eval/run_text_score.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/common/sqlite.hpp"
#include "keyfleet/eval/metrics.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

using KeyframeId = std::pair<std::string, std::int64_t>;  // robot id, sequence number

std::vector<std::string> split_words(const std::string& text) {
  std::vector<std::string> parts;
  std::istringstream in(text);
  for (std::string part; in >> part;)
    if (!normalise_word(part).empty()) parts.push_back(normalise_word(part));
  return parts;
}

std::string join(const std::vector<std::string>& words, std::size_t limit) {
  std::string out;
  for (std::size_t i = 0; i < words.size() && i < limit; ++i) out += (i ? ", " : "") + words[i];
  if (words.size() > limit) out += ", ... (" + std::to_string(words.size() - limit) + " more)";
  return out.empty() ? "-" : out;
}

}  // namespace

RunTextScore score_run_text(const std::string& scenario_dir, const std::string& station_db,
                            const KeyframeFilter& keep) {
  const scenario::Scenario street = scenario::read_scenario(scenario_dir);
  std::set<std::string> street_words;  // every part of every sign's word, normalised
  for (const auto& sign : street.signs)
    for (const auto& part : split_words(sign.text)) street_words.insert(part);
  std::map<std::string, std::vector<scenario::FrameTruth>> truth;  // by robot id
  for (const auto& drone : street.drones)
    truth[drone.robot_id] =
        scenario::read_frame_truth((fs::path(scenario_dir) / drone.folder).string());

  SqliteDb db(station_db, SqliteDb::Mode::kReadOnly);
  std::map<KeyframeId, std::vector<WordRead>> read;
  RunTextScore score;
  std::set<std::string> junk_words;
  auto words = db.prepare("SELECT robot_id, sequence_number, text, x, y, width, height FROM words");
  while (words.step()) {
    if (keep && !keep(words.text(0), words.int64(1))) continue;
    const std::string text = words.text(2);
    const double x = words.real(3), y = words.real(4);
    read[{words.text(0), words.int64(1)}].push_back(
        {text, x, y, x + words.real(5), y + words.real(6)});
    ++score.words_reported;
    const auto parts = split_words(text);
    const bool of_the_street =
        !parts.empty() && std::all_of(parts.begin(), parts.end(), [&](const std::string& p) {
          return street_words.count(p) > 0;
        });
    if (!of_the_street) {
      ++score.junk;
      junk_words.insert(text);
    }
  }

  std::set<std::string> visible, read_there;
  auto keyframes = db.prepare("SELECT robot_id, sequence_number, frame_index FROM keyframes");
  while (keyframes.step()) {
    const auto drone = truth.find(keyframes.text(0));
    const auto frame = std::size_t(keyframes.int64(2));
    if (drone == truth.end() || frame >= drone->second.size()) continue;
    if (keep && !keep(keyframes.text(0), keyframes.int64(1))) continue;
    ++score.keyframes;
    const scenario::FrameTruth& view = drone->second[frame];
    const std::set<int> shown = fully_visible_signs(view);
    const auto it = read.find({keyframes.text(0), keyframes.int64(1)});
    const std::set<int> found = it == read.end() ? std::set<int>{} : signs_read(it->second, view);
    for (const int sign : shown) {
      if (sign < 0 || std::size_t(sign) >= street.signs.size()) continue;
      const std::string word = normalise_word(street.signs[std::size_t(sign)].text);
      visible.insert(word);
      if (found.count(sign)) read_there.insert(word);
    }
  }
  score.visible_words = visible.size();
  score.read_visible = read_there.size();
  score.read_words.assign(read_there.begin(), read_there.end());
  for (const auto& word : visible)
    if (!read_there.count(word)) score.missed_words.push_back(word);
  score.junk_words.assign(junk_words.begin(), junk_words.end());
  return score;
}

std::string format_run_text_score(const RunTextScore& score) {
  char line[256];
  std::snprintf(
      line, sizeof line,
      "Text read against the scenario: %zu of %zu sign words fully visible in the %zu received "
      "keyframes read there (%.0f %%); junk %zu of %zu words reported (%.0f %%)\n",
      score.read_visible, score.visible_words, score.keyframes, 100 * score.read_rate(), score.junk,
      score.words_reported, 100 * score.junk_rate());
  return std::string(line) + "    read: " + join(score.read_words, 20) + "\n" +
         "    missed: " + join(score.missed_words, 20) + "\n" +
         "    junk: " + join(score.junk_words, 20) + "\n";
}

}  // namespace keyfleet::eval
