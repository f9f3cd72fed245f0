#include "keyfleet/station/text/lexicon.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>

#include "keyfleet/common/error.hpp"

namespace keyfleet::station {
namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string upper(std::string s) {
  for (char& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// Levenshtein distance, or `limit + 1` as soon as it is certain to exceed `limit`.
int edit_distance(const std::string& a, const std::string& b, int limit) {
  const int n = int(a.size()), m = int(b.size());
  if (std::abs(n - m) > limit) return limit + 1;
  std::vector<int> previous(std::size_t(m) + 1), current(std::size_t(m) + 1);
  for (int j = 0; j <= m; ++j) previous[std::size_t(j)] = j;
  for (int i = 1; i <= n; ++i) {
    current[0] = i;
    int row_best = i;
    for (int j = 1; j <= m; ++j) {
      const int substitute =
          previous[std::size_t(j - 1)] + (a[std::size_t(i - 1)] == b[std::size_t(j - 1)] ? 0 : 1);
      current[std::size_t(j)] =
          std::min({substitute, previous[std::size_t(j)] + 1, current[std::size_t(j - 1)] + 1});
      row_best = std::min(row_best, current[std::size_t(j)]);
    }
    if (row_best > limit) return limit + 1;
    std::swap(previous, current);
  }
  return previous[std::size_t(m)];
}

bool is_letter(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; }

}  // namespace

Lexicon::Lexicon(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StartupError("lexicon: cannot read '" + path + "'");
  std::string line;
  while (std::getline(in, line)) add(line);
  if (known_.empty()) throw StartupError("lexicon: '" + path + "' holds no word");
}

Lexicon::Lexicon(const std::vector<std::string>& words) {
  for (const auto& word : words) add(word);
}

void Lexicon::add(const std::string& word) {
  const auto first = word.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return;
  const auto last = word.find_last_not_of(" \t\r\n");
  const std::string key = lower(word.substr(first, last - first + 1));
  if (!known_.insert(key).second) return;
  if (by_length_.size() <= key.size()) by_length_.resize(key.size() + 1);
  by_length_[key.size()].push_back(key);
}

int Lexicon::max_edits(std::size_t length) { return length <= 4 ? 0 : length <= 8 ? 1 : 2; }

std::optional<std::string> Lexicon::nearest(const std::string& word) const {
  const std::string key = lower(word);
  if (known_.count(key)) return key;
  const int limit = max_edits(key.size());
  if (limit == 0) return std::nullopt;
  // Same length first: at equal distance a substitution beats an insertion or deletion.
  std::vector<std::size_t> lengths = {key.size()};
  for (int d = 1; d <= limit; ++d) {
    lengths.push_back(key.size() + std::size_t(d));
    if (key.size() > std::size_t(d)) lengths.push_back(key.size() - std::size_t(d));
  }
  std::optional<std::string> best;
  int best_distance = limit + 1;
  for (const std::size_t length : lengths) {
    if (length >= by_length_.size()) continue;
    for (const auto& candidate : by_length_[length]) {
      const int d = edit_distance(key, candidate, best_distance - 1);
      if (d < best_distance) {
        best_distance = d;
        best = candidate;
      }
    }
  }
  return best;
}

std::optional<std::string> apply_lexicon(const Lexicon& lexicon, const std::string& reading) {
  std::size_t begin = 0, end = reading.size();
  while (begin < end && std::ispunct(static_cast<unsigned char>(reading[begin]))) ++begin;
  while (end > begin && std::ispunct(static_cast<unsigned char>(reading[end - 1]))) --end;
  const std::string core = reading.substr(begin, end - begin);
  const auto letters = std::count_if(core.begin(), core.end(), is_letter);
  const bool has_digit = std::any_of(
      core.begin(), core.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
  if (has_digit || letters < 3) return reading;
  auto listed = lexicon.nearest(core);
  if (!listed) return std::nullopt;
  const bool all_upper = std::none_of(
      core.begin(), core.end(), [](char c) { return std::islower(static_cast<unsigned char>(c)); });
  if (all_upper) {
    *listed = upper(*listed);
  } else if (std::isupper(static_cast<unsigned char>(core[0])) && !listed->empty()) {
    (*listed)[0] = char(std::toupper(static_cast<unsigned char>((*listed)[0])));
  }
  return reading.substr(0, begin) + *listed + reading.substr(end);
}

}  // namespace keyfleet::station
