// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file execution.hpp
/// @brief How a call runs, as opposed to what it computes: threads and progress reports.

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>

namespace iires {

/// @brief The execution context of a call. A pipeline (resample(), registerClouds(), reconstruct()) takes one
/// and hands the same context to each of its stages; an algorithm called on its own takes one too (the default:
/// all cores, no reports). No result depends on it: same input and parameters give the same output for any
/// thread count.
struct Execution {
  using Progress = std::function<void(const std::string& stage, double fraction)>;

  Execution() = default;
  explicit Execution(int threadCount, Progress report = {}) : threads(threadCount), progress(std::move(report)) {}

  int threads = 0;  ///< threads of parallel loops; 0 = all cores
  /// Optional progress report: called with a stage name and the fraction of that stage done, in [0, 1], from
  /// the calling thread only. Empty = no reports.
  Progress progress;

  /// Reports @p fraction of @p stage when a progress callback is set.
  void report(const std::string& stage, double fraction) const {
    if (progress) progress(stage, fraction);
  }
  /// @throws std::invalid_argument when threads is negative.
  void validate() const {
    if (threads < 0) throw std::invalid_argument("threads must be >= 0 (0 = all cores)");
  }
};

}  // namespace iires
