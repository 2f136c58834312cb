// SPDX-License-Identifier: GPL-3.0-or-later
#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace iires::tools {

Progress::Progress(std::string tool, bool force, bool quiet) : tool_(std::move(tool)) {
  terminal_ = ::isatty(STDERR_FILENO) == 1;
  enabled_ = !quiet && (force || terminal_);
  start_ = last_ = Clock::now();
}

Progress::~Progress() { finish(); }

void Progress::update(const std::string& stage, double fraction) {
  if (!enabled_) return;
  const auto now = Clock::now();
  if (terminal_ && now - start_ < std::chrono::seconds(1)) return;  // short runs print nothing
  const int percent = static_cast<int>(std::lround(100.0 * std::clamp(fraction, 0.0, 1.0)));
  const bool newStage = stage != stage_;
  if (terminal_) {
    if (!newStage && (percent == lastPercent_ || now - last_ < std::chrono::milliseconds(100))) return;
    std::fprintf(stderr, "\r\033[K%s: %s %3d%%", tool_.c_str(), stage.c_str(), percent);
    lineOpen_ = true;
  } else {
    if (!newStage && percent / 10 == lastPercent_ / 10) return;
    std::fprintf(stderr, "%s: %s %3d%%\n", tool_.c_str(), stage.c_str(), percent);
  }
  std::fflush(stderr);
  stage_ = stage;
  lastPercent_ = percent;
  last_ = now;
}

void Progress::finish() {
  if (lineOpen_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  lineOpen_ = false;
}

std::function<void(const std::string&, double)> Progress::callback() {
  if (!enabled_) return {};
  return [this](const std::string& stage, double fraction) { update(stage, fraction); };
}

}  // namespace iires::tools
