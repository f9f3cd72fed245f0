#include "keyfleet/eval/trigger_comparison.hpp"

#include <algorithm>
#include <cstdio>

#include "keyfleet/agent/keyframe_selector.hpp"
#include "keyfleet/common/clock.hpp"

namespace keyfleet::eval {

std::size_t count_within(const std::vector<std::uint64_t>& keyframes,
                         const std::vector<std::uint64_t>& others, std::uint64_t tolerance) {
  std::size_t n = 0;
  for (const std::uint64_t k : keyframes) {
    const auto it =
        std::lower_bound(others.begin(), others.end(), k > tolerance ? k - tolerance : 0);
    if (it != others.end() && *it <= k + tolerance) ++n;
  }
  return n;
}

TriggerRun run_trigger(const std::vector<agent::Frame>& frames, const TriggerConfig& config,
                       double fps) {
  auto trigger = agent::make_trigger(config, fps);
  TriggerRun run;
  const double start = thread_cpu_ms();
  for (const auto& frame : frames)
    if (trigger->is_keyframe(frame)) run.keyframes.push_back(frame.index);
  if (!frames.empty()) run.cpu_ms_per_frame = (thread_cpu_ms() - start) / double(frames.size());
  return run;
}

TriggerComparison compare_triggers(const std::string& sequence,
                                   const std::vector<agent::Frame>& frames, double fps,
                                   const TriggerConfig& reference, const TriggerConfig& candidate) {
  TriggerComparison c;
  c.sequence = sequence;
  c.frames = frames.size();
  c.reference = run_trigger(frames, reference, fps);
  c.candidate = run_trigger(frames, candidate, fps);
  const auto& r = c.reference.keyframes;
  const auto& k = c.candidate.keyframes;
  c.reference_within_2 = count_within(r, k, 2);
  c.reference_within_5 = count_within(r, k, 5);
  c.candidate_within_2 = count_within(k, r, 2);
  c.candidate_within_5 = count_within(k, r, 5);
  return c;
}

namespace {

std::string line(const TriggerComparison& c, double ref_ms, double cand_ms) {
  auto rate = [&](std::size_t n) { return c.frames ? 100.0 * double(n) / double(c.frames) : 0.0; };
  auto share = [](std::size_t n, std::size_t of) {
    return of ? 100.0 * double(n) / double(of) : 0.0;
  };
  const std::size_t nr = c.reference.keyframes.size(), nk = c.candidate.keyframes.size();
  char text[320];
  std::snprintf(
      text, sizeof text,
      "%-28s %6zu %5zu %5zu %6.1f %6.1f   %3.0f%% %3.0f%%   %3.0f%% %3.0f%%  %7.2f %7.2f\n",
      c.sequence.c_str(), c.frames, nr, nk, rate(nr), rate(nk), share(c.reference_within_2, nr),
      share(c.reference_within_5, nr), share(c.candidate_within_2, nk),
      share(c.candidate_within_5, nk), ref_ms, cand_ms);
  return text;
}

}  // namespace

std::string format_comparisons(const std::vector<TriggerComparison>& comparisons,
                               const std::string& reference_name,
                               const std::string& candidate_name) {
  std::string out = "reference R = " + reference_name + ", candidate C = " + candidate_name +
                    "; near: keyframes of one with a keyframe of the other within +-2 / +-5 "
                    "frames\n";
  char head[320];
  std::snprintf(head, sizeof head, "%-28s %6s %5s %5s %6s %6s   %-9s   %-9s  %7s %7s\n", "sequence",
                "frames", "kf R", "kf C", "R/100", "C/100", "R near C", "C near R", "R ms/f",
                "C ms/f");
  out += head;
  TriggerComparison total;
  total.sequence = "TOTAL";
  double ref_ms = 0, cand_ms = 0;
  for (const auto& c : comparisons) {
    out += line(c, c.reference.cpu_ms_per_frame, c.candidate.cpu_ms_per_frame);
    total.frames += c.frames;
    total.reference.keyframes.insert(total.reference.keyframes.end(), c.reference.keyframes.begin(),
                                     c.reference.keyframes.end());
    total.candidate.keyframes.insert(total.candidate.keyframes.end(), c.candidate.keyframes.begin(),
                                     c.candidate.keyframes.end());
    total.reference_within_2 += c.reference_within_2;
    total.reference_within_5 += c.reference_within_5;
    total.candidate_within_2 += c.candidate_within_2;
    total.candidate_within_5 += c.candidate_within_5;
    ref_ms += c.reference.cpu_ms_per_frame * double(c.frames);
    cand_ms += c.candidate.cpu_ms_per_frame * double(c.frames);
  }
  if (comparisons.size() > 1 && total.frames > 0)
    out += line(total, ref_ms / double(total.frames), cand_ms / double(total.frames));
  return out;
}

}  // namespace keyfleet::eval
