// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file stage_clock.hpp
/// @brief StageClock (internal): the stage timer and progress reporter of the pipelines.

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "iires/resample.hpp"  // StageTime

namespace iires {

/// @brief Times the stages of a pipeline into a list of StageTime and reports each stage's start (0) and end
/// (1) to a progress callback (the closing "total" is timed, not reported). Shared by the pipelines built on
/// resample() so that their reports and progress look alike.
class StageClock {
 public:
  using Progress = std::function<void(const std::string& stage, double fraction)>;
  StageClock(std::vector<StageTime>& timings, const Progress& progress) : timings_(timings), progress_(progress) {}
  std::chrono::steady_clock::time_point begin(const char* name) const {
    if (progress_) progress_(name, 0.0);
    return std::chrono::steady_clock::now();
  }
  void end(const char* name, std::chrono::steady_clock::time_point start) const {
    timings_.push_back({name, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
    if (progress_ && std::string(name) != "total") progress_(name, 1.0);
  }

 private:
  std::vector<StageTime>& timings_;
  const Progress& progress_;
};

}  // namespace iires
