#include "keyfleet/station/places/bow_matching.hpp"

#include <algorithm>
#include <limits>

#include "hamming.hpp"

namespace keyfleet::station {
namespace {

bool usable(const cv::Mat& d) { return !d.empty() && d.type() == CV_8UC1 && d.cols == 32; }

}  // namespace

std::vector<cv::DMatch> match_with_direct_index(const cv::Mat& query_desc,
                                                const FeatureVector& query_fv,
                                                const cv::Mat& train_desc,
                                                const FeatureVector& train_fv, int max_hamming,
                                                float ratio) {
  std::vector<cv::DMatch> candidates;
  if (!usable(query_desc) || !usable(train_desc)) return candidates;
  auto q = query_fv.begin();
  auto t = train_fv.begin();
  while (q != query_fv.end() && t != train_fv.end()) {
    if (q->node < t->node) {
      ++q;
      continue;
    }
    if (t->node < q->node) {
      ++t;
      continue;
    }
    for (std::uint32_t qi : q->features) {
      if (int(qi) >= query_desc.rows) continue;  // a direct index of another matrix
      const std::uint8_t* qd = query_desc.ptr<std::uint8_t>(int(qi));
      int best = std::numeric_limits<int>::max(), second = best;
      std::uint32_t best_row = 0;
      for (std::uint32_t ti : t->features) {
        if (int(ti) >= train_desc.rows) continue;
        const int d = detail::hamming256(qd, train_desc.ptr<std::uint8_t>(int(ti)));
        if (d < best) {
          second = best;
          best = d;
          best_row = ti;
        } else if (d < second) {
          second = d;
        }
      }
      if (best > max_hamming) continue;
      // Alone in its node the best has no rival: the distance threshold decides.
      if (second != std::numeric_limits<int>::max() && float(best) >= ratio * float(second))
        continue;
      candidates.emplace_back(int(qi), int(best_row), float(best));
    }
    ++q;
    ++t;
  }
  // One-to-one: each train row keeps its closest query (ties: the lower query row).
  std::sort(candidates.begin(), candidates.end(), [](const cv::DMatch& a, const cv::DMatch& b) {
    if (a.trainIdx != b.trainIdx) return a.trainIdx < b.trainIdx;
    if (a.distance != b.distance) return a.distance < b.distance;
    return a.queryIdx < b.queryIdx;
  });
  std::vector<cv::DMatch> out;
  for (const auto& m : candidates)
    if (out.empty() || out.back().trainIdx != m.trainIdx) out.push_back(m);
  std::sort(out.begin(), out.end(),
            [](const cv::DMatch& a, const cv::DMatch& b) { return a.queryIdx < b.queryIdx; });
  return out;
}

}  // namespace keyfleet::station
