#include "keyfleet/agent/send_controller.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>

namespace keyfleet::agent {
namespace {

constexpr double kSelectionWindowS = 30.0;  // the selection rate is taken over this long
constexpr double kCostGain = 0.3;           // a new cost moves the learnt one this much
constexpr double kOverrun = 1.15;           // offered over budget that steps down at once

// A baseline JPEG's size against its quality on camera frames, relative to quality 85 (libjpeg's
// quantisation scaling; measured sizes replace it as soon as there are any).
double relative_jpeg_bytes(int quality) {
  static constexpr std::array<std::pair<int, double>, 10> kTable = {{{10, 0.15},
                                                                     {20, 0.23},
                                                                     {30, 0.30},
                                                                     {40, 0.36},
                                                                     {50, 0.43},
                                                                     {60, 0.52},
                                                                     {70, 0.64},
                                                                     {85, 1.00},
                                                                     {95, 1.90},
                                                                     {100, 3.50}}};
  if (quality <= kTable.front().first) return kTable.front().second;
  for (std::size_t i = 1; i < kTable.size(); ++i) {
    if (quality <= kTable[i].first) {
      const auto [q0, r0] = kTable[i - 1];
      const auto [q1, r1] = kTable[i];
      return r0 + (r1 - r0) * (quality - q0) / double(q1 - q0);
    }
  }
  return kTable.back().second;
}

double model_bytes(const SendLevel& level) {
  return relative_jpeg_bytes(level.jpeg_quality) * level.scale * level.scale;
}

double ns_to_s(std::int64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace

std::vector<SendLevel> send_ladder(const LinkAdaptationConfig& config, int jpeg_quality) {
  std::vector<SendLevel> ladder = {SendLevel{jpeg_quality, 1.0, 1}};
  for (const int q : config.jpeg_qualities)
    if (q < ladder.back().jpeg_quality) ladder.push_back({q, 1.0, 1});
  for (const double s : config.scales)
    if (s < ladder.back().scale) ladder.push_back({ladder.back().jpeg_quality, s, 1});
  for (int d = 2; d <= config.max_density; ++d)
    ladder.push_back({ladder.back().jpeg_quality, ladder.back().scale, d});
  return ladder;
}

std::string describe(const SendLevel& level) {
  std::string text =
      fmt::format("JPEG q{} at {:g} of the frame's size", level.jpeg_quality, level.scale);
  if (level.density > 1) text += fmt::format(", one selection in {} at once", level.density);
  return text;
}

SendController::SendController(const LinkAdaptationConfig& config, int jpeg_quality)
    : config_(config), ladder_(send_ladder(config, jpeg_quality)), cost_(ladder_.size(), 0.0) {}

void SendController::on_selection(std::int64_t now_ns) {
  now_ns_ = std::max(now_ns_, now_ns);
  selections_.push_back(now_ns);
}

void SendController::on_cost(std::size_t level, std::uint64_t bytes) {
  if (level >= cost_.size()) return;
  // Density does not change what one keyframe costs: every rung with the same encoding learns.
  for (std::size_t i = 0; i < ladder_.size(); ++i) {
    if (ladder_[i].jpeg_quality != ladder_[level].jpeg_quality ||
        ladder_[i].scale != ladder_[level].scale)
      continue;
    cost_[i] = cost_[i] == 0 ? double(bytes) : cost_[i] + kCostGain * (double(bytes) - cost_[i]);
  }
}

bool SendController::send_now() {
  const int density = ladder_[level_].density;
  return density <= 1 || density_counter_++ % static_cast<std::uint64_t>(density) == 0;
}

double SendController::selections_per_s() const {
  if (selections_.size() < 2) return 0.0;
  // The intervals since the oldest selection in the window, up to now: a robot that stops
  // selecting sees the rate fall.
  const double span = ns_to_s(now_ns_ - selections_.front());
  return static_cast<double>(selections_.size() - 1) / std::max(span, 1.0);
}

double SendController::offered_bytes_per_s(std::size_t level) const {
  return selections_per_s() * keyframe_bytes(level) / ladder_[level].density;
}

double SendController::keyframe_bytes(std::size_t level) const {
  double cost = cost_[level];
  if (cost == 0) {
    // Not measured yet: scaled from the nearest measured rung by the JPEG model.
    double best = 0;
    std::size_t nearest = level;
    for (std::size_t i = 0; i < cost_.size(); ++i) {
      if (cost_[i] == 0) continue;
      const double distance = std::abs(double(i) - double(level));
      if (best == 0 || distance < best) {
        best = distance;
        nearest = i;
      }
    }
    if (best == 0) return 0.0;  // nothing measured: no basis to choose on
    cost = cost_[nearest] * model_bytes(ladder_[level]) / model_bytes(ladder_[nearest]);
  }
  return cost;
}

double SendController::backlog_wait_s(const LinkEstimate& link, std::uint64_t backlog_bytes) {
  if (backlog_bytes == 0 || !link.known) return 0.0;
  if (link.delivery_bytes_per_s <= 0) return std::numeric_limits<double>::infinity();
  return static_cast<double>(backlog_bytes) / link.delivery_bytes_per_s;
}

std::size_t SendController::richest_fitting(double budget_bytes_per_s) const {
  for (std::size_t i = 0; i < ladder_.size(); ++i)
    if (offered_bytes_per_s(i) <= budget_bytes_per_s) return i;
  return ladder_.size() - 1;
}

std::optional<LevelChange> SendController::update(std::int64_t now_ns, const LinkEstimate& link,
                                                  std::uint64_t backlog_bytes) {
  now_ns_ = std::max(now_ns_, now_ns);
  while (selections_.size() > 2 && ns_to_s(now_ns_ - selections_.front()) > kSelectionWindowS)
    selections_.pop_front();
  if (!config_.enabled || !link.known || selections_.empty()) return std::nullopt;
  const double target = config_.latency_target_s;
  const double rate = link.delivery_bytes_per_s;
  const double wait = backlog_wait_s(link, backlog_bytes);
  const auto change = [&](std::size_t to, std::string reason) {
    LevelChange c{level_, to, std::move(reason)};
    level_ = to;
    last_change_ns_ = now_ns;
    room_since_ns_ = -1;
    density_counter_ = 0;
    return c;
  };
  if (selections_.size() < 2) {
    // No selection rate yet (the flight's first keyframe): it alone must cross the link, as
    // estimated (the prior until something is measured), within half the target; a backlog
    // made of a first keyframe too rich for the link would otherwise be drained by thinning.
    std::size_t fit = level_;
    while (fit + 1 < ladder_.size() && ladder_[fit + 1].density == 1 &&
           keyframe_bytes(fit) > rate * target / 2)
      ++fit;
    if (fit == level_) return std::nullopt;
    return change(fit, fmt::format("the first keyframe at the current level ({:.1f} kB) would "
                                   "take {:.1f} s at {:.1f} kB/s (target {:g} s)",
                                   keyframe_bytes(level_) / 1e3, keyframe_bytes(level_) / rate,
                                   rate / 1e3, target));
  }
  // What new keyframes may offer: the planned share of the rate, less what drains the part of
  // the backlog above half the target within the target.
  const double excess = std::max(0.0, double(backlog_bytes) - rate * target / 2);
  const double budget = config_.utilisation * rate - excess / target;
  std::size_t fit = richest_fitting(budget);
  // Thinning only when even the cheapest encoding does not fit the planned share of the rate:
  // a backlog that the cheapest encoding drains is drained without it.
  std::size_t cheapest_encoding = 0;
  while (cheapest_encoding + 1 < ladder_.size() && ladder_[cheapest_encoding + 1].density == 1)
    ++cheapest_encoding;
  if (fit > cheapest_encoding &&
      offered_bytes_per_s(cheapest_encoding) <= config_.utilisation * rate && !std::isinf(wait))
    fit = cheapest_encoding;
  // Down at once when the backlog waits half the target or the current level clearly overruns
  // the budget; a level a little over it (a cost estimate's noise) waits until the backlog says
  // so, which keeps a link near a rung's cost from flapping between two rungs.
  const bool overrun =
      fit > level_ && (wait > target / 2 || offered_bytes_per_s(level_) > kOverrun * budget);
  if (overrun || (std::isinf(wait) && level_ + 1 < ladder_.size())) {
    const std::size_t to = std::isinf(wait) ? ladder_.size() - 1 : fit;
    return change(to, fmt::format("backlog {:.1f} s at {:.1f} kB/s, {:.1f} kB/s offered at the "
                                  "current level (target {:g} s)",
                                  wait, rate / 1e3, offered_bytes_per_s(level_) / 1e3, target));
  }
  if (fit < level_ && wait < target / 4) {
    if (room_since_ns_ < 0) room_since_ns_ = now_ns;
    if (ns_to_s(now_ns - room_since_ns_) >= config_.raise_after_s &&
        ns_to_s(now_ns - last_change_ns_) >= config_.raise_after_s)
      return change(level_ - 1,
                    fmt::format("room on the link: {:.1f} kB/s delivered, {:.1f} kB/s offered at "
                                "the richer level, backlog {:.1f} s",
                                rate / 1e3, offered_bytes_per_s(level_ - 1) / 1e3, wait));
  } else {
    room_since_ns_ = -1;
  }
  return std::nullopt;
}

}  // namespace keyfleet::agent
