#include "keyfleet/station/analysis_pool.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "keyfleet/common/thread_name.hpp"

namespace keyfleet::station {

AnalysisPool::AnalysisPool(std::vector<Step> workers, std::size_t capacity, Logger logger,
                           StartHook on_start)
    : capacity_(std::max<std::size_t>(capacity, 1)),
      logger_(std::move(logger)),
      on_start_(std::move(on_start)) {
  threads_.reserve(workers.size());
  for (std::size_t i = 0; i < workers.size(); ++i)
    threads_.emplace_back([this, i, step = std::move(workers[i])] {
      name_this_thread("analysis-" + std::to_string(i));
      run(step);
    });
}

AnalysisPool::~AnalysisPool() { stop(); }

void AnalysisPool::submit(AnalysisJob job) {
  std::lock_guard lock(mutex_);
  if (waiting_.size() >= capacity_) {
    AnalysisJob& oldest = waiting_.front();
    AnalysisResult deferred;
    deferred.key = oldest.key;
    deferred.capture_time_ns = oldest.capture_time_ns;
    deferred.status = AnalysisStatus::kDeferred;
    deferred.detail = "analysis queue full (" + std::to_string(capacity_) + " waiting)";
    logger_->warn("analysis of {} deferred: {}", to_string(oldest.key), deferred.detail);
    results_.push_back(std::move(deferred));
    waiting_.pop_front();
    submitted_.pop_front();
    ++counters_.deferred;
  }
  waiting_.push_back(std::move(job));
  submitted_.push_back(std::chrono::steady_clock::now());
  work_ready_.notify_one();
}

void AnalysisPool::run(const Step& step) {
  std::unique_lock lock(mutex_);
  while (true) {
    work_ready_.wait(lock, [&] { return stopping_ || !waiting_.empty(); });
    if (stopping_) return;
    AnalysisJob job = std::move(waiting_.front());
    waiting_.pop_front();
    const auto submitted = submitted_.front();
    submitted_.pop_front();
    ++counters_.running;
    lock.unlock();
    if (on_start_) {
      try {
        on_start_(job.key);
      } catch (const std::exception& e) {
        logger_->error("could not record the start of {}'s analysis: {}", to_string(job.key),
                       e.what());
      }
    }
    AnalysisResult result;
    try {
      result = step(job);
    } catch (const std::exception& e) {
      // A step should not throw; if an engine does, the keyframe is marked, not lost.
      result.key = job.key;
      result.capture_time_ns = job.capture_time_ns;
      result.status = AnalysisStatus::kFailed;
      result.detail = std::string("analysis failed: ") + e.what();
      logger_->error("analysis of {} failed: {}", to_string(job.key), e.what());
    }
    const std::chrono::duration<float> latency = std::chrono::steady_clock::now() - submitted;
    lock.lock();
    latencies_s_.push_back(latency.count());
    results_.push_back(std::move(result));
    --counters_.running;
    ++counters_.analysed;
    if (waiting_.empty() && counters_.running == 0) became_idle_.notify_all();
  }
}

std::vector<AnalysisResult> AnalysisPool::take_results() {
  std::lock_guard lock(mutex_);
  std::vector<AnalysisResult> out;
  out.swap(results_);
  return out;
}

bool AnalysisPool::idle() const {
  std::lock_guard lock(mutex_);
  return waiting_.empty() && counters_.running == 0;
}

bool AnalysisPool::wait_until_idle(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return became_idle_.wait_for(lock, timeout,
                               [&] { return waiting_.empty() && counters_.running == 0; });
}

AnalysisPool::Counters AnalysisPool::counters() const {
  std::lock_guard lock(mutex_);
  Counters c = counters_;
  c.waiting = waiting_.size();
  return c;
}

AnalysisPool::Latency AnalysisPool::latency() const {
  std::vector<float> sorted;
  {
    std::lock_guard lock(mutex_);
    sorted = latencies_s_;
  }
  Latency l;
  l.count = sorted.size();
  if (sorted.empty()) return l;
  std::sort(sorted.begin(), sorted.end());
  // The nearest rank: the smallest value with at least q of the values at or below it.
  const auto rank = [&](double q) {
    const auto at = std::size_t(std::max(1.0, std::ceil(q * double(sorted.size())))) - 1;
    return double(sorted[at]);
  };
  l.p50_s = rank(0.50);
  l.p95_s = rank(0.95);
  l.max_s = double(sorted.back());
  return l;
}

void AnalysisPool::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    waiting_.clear();
    submitted_.clear();
  }
  work_ready_.notify_all();
  for (auto& t : threads_) t.join();
  threads_.clear();
}

}  // namespace keyfleet::station
