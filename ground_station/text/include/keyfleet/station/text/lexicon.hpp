#pragma once
// A word list the station's readings are checked and corrected against (ICDAR's lexicon tracks):
// Debian's wamerican (/usr/share/dict/american-english) or a mission's own list of expected words.
#include <cstddef>
#include <optional>
#include <string>
#include <unordered_set>
#include <vector>

namespace keyfleet::station {

class Lexicon {
 public:
  // One word a line (UTF-8; empty lines and surrounding blanks ignored). Throws StartupError
  // when the file cannot be read or holds no word.
  explicit Lexicon(const std::string& path);
  explicit Lexicon(const std::vector<std::string>& words);

  // The listed word `word` is taken to be, lower-case: itself when listed (ignoring ASCII case);
  // else the listed word nearest in edit distance, within max_edits(word), a substitution
  // preferred to an insertion or deletion, then the first in the list; nullopt when none is
  // that near.
  std::optional<std::string> nearest(const std::string& word) const;

  // Edits allowed for a word of `length` bytes: none up to 4, one up to 8, two beyond.
  static int max_edits(std::size_t length);

  std::size_t size() const { return known_.size(); }

 private:
  void add(const std::string& word);

  std::unordered_set<std::string> known_;            // lower-case
  std::vector<std::vector<std::string>> by_length_;  // lower-case, in list order, by byte length
};

// A read word checked against `lexicon`: words with a digit and words shorter than 3 letters
// pass unchanged (numbers, codes); otherwise the word between its leading and trailing
// punctuation is replaced by its nearest listed word in the reading's case (UPPER, Capitalised
// or lower), or nullopt when no listed word is near enough (the reading is then dropped).
std::optional<std::string> apply_lexicon(const Lexicon& lexicon, const std::string& reading);

}  // namespace keyfleet::station
