#pragma once
// The evaluation's measures as plain functions, so that each can be checked on hand-made
// cases: which keyframes a density keeps, word recall, top-k retrieval, bytes sent.
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "keyfleet/common/scenario_truth.hpp"

namespace keyfleet::eval {

// Which of n items a kept fraction keeps: round(fraction * n) of them (at least one when
// n > 0), item floor((2i + 1) n / 2m) for i < m, i.e. the middle of m equal slices. With
// fraction 1 every item is kept; the same fraction always keeps the same items.
std::vector<std::size_t> spread_evenly(std::size_t n, double fraction);

// |found ∩ relevant| / |relevant|; 0 when nothing is relevant.
double recall(const std::set<int>& found, const std::set<int>& relevant);

// Signs (ids) whose word is legible and fully visible in the frame.
std::set<int> fully_visible_signs(const scenario::FrameTruth& frame);

// Upper-case letters and digits only ("Café-Bar" -> "CAFBAR"), for comparing words read
// with the ground truth's.
std::string normalise_word(const std::string& text);

struct WordRead {
  std::string text;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // box in frame pixels
};

// Signs read in a frame: a ground-truth word (legible, any visibility) counts as read when
// each of its space-separated parts equals a word read (normalised) whose box overlaps the
// truth's box grown by `margin_px`. The position check keeps a word read elsewhere in the
// frame (a different sign with the same text) from counting.
std::set<int> signs_read(const std::vector<WordRead>& read, const scenario::FrameTruth& frame,
                         double margin_px = 4);

// Top-k place retrieval with ground truth by position: a query is right at k when one of the
// first k retrieved keyframes lies within `tolerance_m` of the query's street position.
struct TopK {
  std::size_t queries = 0;
  std::size_t top1 = 0, top5 = 0;  // right at k = 1 and within the first 5
  double top1_rate() const { return queries ? double(top1) / double(queries) : 0; }
  double top5_rate() const { return queries ? double(top5) / double(queries) : 0; }
};
// `retrieved_positions`: street positions of the retrieved keyframes, best first (may hold
// fewer than 5, or none). Adds one query to `acc`.
void add_query(TopK& acc, double query_position_m, const std::vector<double>& retrieved_positions,
               double tolerance_m);

// Whether a query can be answered at all: some candidate position within the tolerance.
bool answerable(double query_position_m, const std::vector<double>& candidate_positions,
                double tolerance_m);

// Bytes sent for a selection: the sum over every selected frame (a frame selected twice is
// sent twice) of its encoded size; frames without a known size count as 0.
std::uint64_t bytes_sent(const std::vector<std::uint64_t>& selected_frames,
                         const std::vector<std::uint64_t>& encoded_bytes_by_frame);

}  // namespace keyfleet::eval
