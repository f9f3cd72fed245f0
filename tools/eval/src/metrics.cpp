#include "keyfleet/eval/metrics.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace keyfleet::eval {

std::vector<std::size_t> spread_evenly(std::size_t n, double fraction) {
  if (n == 0 || !(fraction > 0)) return {};
  const std::size_t m =
      std::clamp<std::size_t>(std::size_t(std::llround(std::min(fraction, 1.0) * double(n))), 1, n);
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < m; ++i) kept.push_back((2 * i + 1) * n / (2 * m));
  return kept;
}

double recall(const std::set<int>& found, const std::set<int>& relevant) {
  if (relevant.empty()) return 0;
  std::size_t hits = 0;
  for (int r : relevant) hits += found.count(r);
  return double(hits) / double(relevant.size());
}

std::set<int> fully_visible_signs(const scenario::FrameTruth& frame) {
  std::set<int> signs;
  for (const auto& w : frame.words)
    if (w.legible && w.visibility == scenario::WordVisibility::kFull) signs.insert(w.sign_id);
  return signs;
}

std::string normalise_word(const std::string& text) {
  std::string out;
  for (unsigned char c : text)
    if (std::isalnum(c)) out.push_back(char(std::toupper(c)));
  return out;
}

std::set<int> signs_read(const std::vector<WordRead>& read, const scenario::FrameTruth& frame,
                         double margin_px) {
  std::set<int> signs;
  for (const auto& truth : frame.words) {
    if (!truth.legible) continue;
    const double x0 = truth.box_x0 - margin_px, y0 = truth.box_y0 - margin_px;
    const double x1 = truth.box_x1 + margin_px, y1 = truth.box_y1 + margin_px;
    std::istringstream parts(truth.text);
    std::string part;
    bool any = false, all = true;
    while (parts >> part) {
      const std::string want = normalise_word(part);
      if (want.empty()) continue;
      any = true;
      const bool found = std::any_of(read.begin(), read.end(), [&](const WordRead& r) {
        const bool overlaps = r.x0 < x1 && r.x1 > x0 && r.y0 < y1 && r.y1 > y0;
        return overlaps && normalise_word(r.text) == want;
      });
      all = all && found;
    }
    if (any && all) signs.insert(truth.sign_id);
  }
  return signs;
}

void add_query(TopK& acc, double query_position_m, const std::vector<double>& retrieved_positions,
               double tolerance_m) {
  ++acc.queries;
  for (std::size_t i = 0; i < retrieved_positions.size() && i < 5; ++i) {
    if (std::abs(retrieved_positions[i] - query_position_m) > tolerance_m) continue;
    if (i == 0) ++acc.top1;
    ++acc.top5;
    return;
  }
}

bool answerable(double query_position_m, const std::vector<double>& candidate_positions,
                double tolerance_m) {
  return std::any_of(candidate_positions.begin(), candidate_positions.end(),
                     [&](double p) { return std::abs(p - query_position_m) <= tolerance_m; });
}

std::uint64_t bytes_sent(const std::vector<std::uint64_t>& selected_frames,
                         const std::vector<std::uint64_t>& encoded_bytes_by_frame) {
  std::uint64_t total = 0;
  for (auto f : selected_frames)
    if (f < encoded_bytes_by_frame.size()) total += encoded_bytes_by_frame[f];
  return total;
}

}  // namespace keyfleet::eval
