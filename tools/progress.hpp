// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A small progress reporter for the tools: "<tool>: <stage> 42%" on stderr.
#include <chrono>
#include <functional>
#include <string>

namespace iires::tools {

/// @brief Progress on stderr (DESIGN §6): stage name and percentage, for work longer than about a second.
///
/// Enabled automatically only when stderr is a terminal; `--progress` forces it on (e.g. into a log file),
/// `--quiet` switches it off (and wins over `--progress`). On a terminal the line is rewritten in place
/// ("\r") and nothing is shown during the first second; when forced onto a non-terminal, each stage and every
/// further 10 % is printed on its own line. Updates are throttled to ten per second.
class Progress {
 public:
  /// @param tool name printed at the start of each line
  /// @param force `--progress` was given
  /// @param quiet `--quiet` was given
  Progress(std::string tool, bool force, bool quiet);
  ~Progress();

  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  /// Whether anything will be printed.
  bool enabled() const { return enabled_; }

  /// Report @p fraction (0..1) of stage @p stage. Thread-compatible, not thread-safe: call from one thread.
  void update(const std::string& stage, double fraction);

  /// Finish the line (if one was printed). Called by the destructor too.
  void finish();

  /// A callback for library Params (e.g. ResampleParams::progress); empty when disabled.
  std::function<void(const std::string&, double)> callback();

 private:
  using Clock = std::chrono::steady_clock;
  std::string tool_;
  bool enabled_ = false;
  bool terminal_ = false;
  bool lineOpen_ = false;
  Clock::time_point start_, last_;
  std::string stage_;
  int lastPercent_ = -1;
};

}  // namespace iires::tools
