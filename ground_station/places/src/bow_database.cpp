#include "keyfleet/station/places/bow_database.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace keyfleet::station {

std::uint32_t BowDatabase::add(const BowVector& bow, FeatureVector direct) {
  const auto entry = std::uint32_t(direct_.size());
  for (const BowEntry& e : bow) {
    if (!(e.weight > 0)) continue;  // adds nothing to any score
    if (e.word >= inverted_.size()) inverted_.resize(std::size_t(e.word) + 1);
    inverted_[e.word].push_back({entry, float(e.weight)});
  }
  direct_.push_back(std::move(direct));
  return entry;
}

std::vector<BowMatch> BowDatabase::query(const BowVector& bow, std::size_t max_results,
                                         const std::function<bool(std::uint32_t)>& accept) const {
  std::vector<BowMatch> out;
  if (max_results == 0 || direct_.empty()) return out;
  // Dense accumulator (one double per entry, zeroed in one pass) but only the entries met in
  // the query words' posting lists are visited afterwards.
  std::vector<double> score(direct_.size(), 0.0);
  std::vector<std::uint32_t> touched;
  for (const BowEntry& q : bow) {
    if (q.word >= inverted_.size() || !(q.weight > 0)) continue;
    for (const Posting& p : inverted_[q.word]) {
      if (score[p.entry] == 0.0) touched.push_back(p.entry);
      // For L1-normalised vectors 1 - 0.5 |v - w|_1 = sum over shared words of min(v_i, w_i).
      score[p.entry] += std::min(q.weight, double(p.weight));
    }
  }
  out.reserve(touched.size());
  for (std::uint32_t e : touched)
    if (!accept || accept(e)) out.push_back({e, score[e]});
  auto better = [](const BowMatch& a, const BowMatch& b) {
    return a.score > b.score || (a.score == b.score && a.entry < b.entry);
  };
  const std::size_t keep = std::min(max_results, out.size());
  std::partial_sort(out.begin(), out.begin() + std::ptrdiff_t(keep), out.end(), better);
  out.resize(keep);
  return out;
}

const FeatureVector& BowDatabase::direct_index(std::uint32_t entry) const {
  if (entry >= direct_.size())
    throw std::out_of_range("BowDatabase: no entry " + std::to_string(entry));
  return direct_[entry];
}

}  // namespace keyfleet::station
