#pragma once
#include <map>
#include <string>
#include <vector>

#include "keyfleet/common/clock.hpp"
#include "keyfleet/common/types.hpp"

namespace keyfleet::agent {

// Accumulates CPU time (of the calling thread) per named pipeline stage.
class StageClock {
 public:
  class Scope {
   public:
    Scope(StageClock& clock, const std::string& stage)
        : clock_(clock), stage_(stage), start_ms_(thread_cpu_ms()) {}
    ~Scope() { clock_.add(stage_, thread_cpu_ms() - start_ms_); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageClock& clock_;
    std::string stage_;
    double start_ms_;
  };

  Scope measure(const std::string& stage) { return Scope(*this, stage); }
  void add(const std::string& stage, double cpu_ms) {
    StageTime& t = stages_[stage];
    t.stage = stage;
    t.cpu_ms_total += cpu_ms;
    ++t.calls;
  }
  std::vector<StageTime> snapshot() const {
    std::vector<StageTime> out;
    for (const auto& [name, time] : stages_) out.push_back(time);
    return out;
  }

 private:
  std::map<std::string, StageTime> stages_;
};

}  // namespace keyfleet::agent
