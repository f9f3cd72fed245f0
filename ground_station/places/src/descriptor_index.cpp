#include "keyfleet/station/places/descriptor_index.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace keyfleet::station {
namespace {

// Eight independent sums (one vector register's lanes), so the compiler vectorises the loop
// without reordering a reduction.
template <int kLanes = 8>
inline float lane_dot(const float* a, const float* b, int n) {
  float lanes[kLanes] = {};
  int i = 0;
  for (; i + kLanes <= n; i += kLanes)
    for (int j = 0; j < kLanes; ++j) lanes[j] += a[i + j] * b[i + j];
  float sum = 0;
  for (; i < n; ++i) sum += a[i] * b[i];
  for (float lane : lanes) sum += lane;
  return sum;
}

float dot_baseline(const float* a, const float* b, int n) { return lane_dot(a, b, n); }

// The same loop compiled for AVX2 + FMA, called only where the CPU has both.
__attribute__((target("avx2,fma"))) float dot_avx2(const float* a, const float* b, int n) {
  return lane_dot(a, b, n);
}

using DotFunction = float (*)(const float*, const float*, int);

DotFunction pick_dot() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") ? dot_avx2 : dot_baseline;
}

void check_length(const std::vector<float>& descriptor, int dimensions) {
  if (descriptor.size() != static_cast<std::size_t>(dimensions))
    throw std::invalid_argument("place descriptor of " + std::to_string(descriptor.size()) +
                                " values, the index holds " + std::to_string(dimensions));
}

}  // namespace

DescriptorIndex::DescriptorIndex(int dimensions) : dimensions_(dimensions) {
  if (dimensions <= 0) throw std::invalid_argument("descriptor index: dimensions must be > 0");
}

std::uint32_t DescriptorIndex::add(const std::vector<float>& descriptor) {
  check_length(descriptor, dimensions_);
  const auto entry = static_cast<std::uint32_t>(size());
  rows_.insert(rows_.end(), descriptor.begin(), descriptor.end());
  return entry;
}

std::vector<DescriptorMatch> DescriptorIndex::query(
    const std::vector<float>& descriptor, std::size_t max_results,
    const std::function<bool(std::uint32_t)>& accept) const {
  check_length(descriptor, dimensions_);
  static const DotFunction dot = pick_dot();
  std::vector<DescriptorMatch> all;
  all.reserve(size());
  for (std::uint32_t e = 0; e < size(); ++e) {
    if (accept && !accept(e)) continue;
    all.push_back(
        {e, dot(descriptor.data(), rows_.data() + std::size_t(e) * dimensions_, dimensions_)});
  }
  const auto better = [](const DescriptorMatch& a, const DescriptorMatch& b) {
    return a.similarity != b.similarity ? a.similarity > b.similarity : a.entry < b.entry;
  };
  const std::size_t k = std::min(max_results, all.size());
  std::partial_sort(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(k), all.end(), better);
  all.resize(k);
  return all;
}

}  // namespace keyfleet::station
