#pragma once
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "keyfleet/common/logging.hpp"
#include "keyfleet/station/analysis_types.hpp"

namespace keyfleet::station {

// Runs the analysis step on worker threads behind a bounded queue, apart from the DDS
// reader: submit() never blocks. Overload policy: when the queue is full, the oldest
// waiting job is deferred (a kDeferred result, no heavy work now); the station analyses
// deferred keyframes later from its database, when the queue has emptied.
class AnalysisPool {
 public:
  using Step = std::function<AnalysisResult(const AnalysisJob&)>;
  // Runs on the worker just before the step (AnalysisAttempts::started); if it throws, the
  // error is logged and the step runs all the same.
  using StartHook = std::function<void(const KeyframeKey&)>;

  struct Counters {
    std::size_t waiting = 0;
    std::size_t running = 0;
    std::size_t analysed = 0;  // results with status kDone or kFailed
    std::size_t deferred = 0;  // deferred by the overload policy, in total
  };
  // From submit() to the result (done or failed) of each keyframe analysed, seconds: whether
  // the station reads as fast as keyframes arrive (`keyfleet bench fleet`'s read wait). Kept
  // for the whole run, 4 bytes a keyframe analysed (a day at 10 keyframes a second: 3.5 MB).
  struct Latency {
    std::size_t count = 0;
    double p50_s = 0, p95_s = 0, max_s = 0;
  };

  // One step per worker thread (each may own engines that are not thread-safe).
  AnalysisPool(std::vector<Step> workers, std::size_t capacity, Logger logger,
               StartHook on_start = {});
  ~AnalysisPool();
  AnalysisPool(const AnalysisPool&) = delete;
  AnalysisPool& operator=(const AnalysisPool&) = delete;

  void submit(AnalysisJob job);
  std::vector<AnalysisResult> take_results();
  // True when nothing waits or runs (results may still wait to be taken).
  bool idle() const;
  bool wait_until_idle(std::chrono::milliseconds timeout);
  Counters counters() const;
  Latency latency() const;
  // Lets the running steps finish and joins; waiting jobs are dropped from memory (they
  // are stored, unanalysed, and the station picks them up when it next starts).
  void stop();

 private:
  void run(const Step& step);

  std::size_t capacity_;
  Logger logger_;
  StartHook on_start_;
  mutable std::mutex mutex_;
  std::condition_variable work_ready_;
  std::condition_variable became_idle_;
  std::deque<AnalysisJob> waiting_;
  std::deque<std::chrono::steady_clock::time_point> submitted_;  // waiting_'s, in its order
  std::vector<float> latencies_s_;                               // one a keyframe analysed
  std::vector<AnalysisResult> results_;
  Counters counters_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace keyfleet::station
