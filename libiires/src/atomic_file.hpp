// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Temporary files that become outputs only when a run commits them (io's OutputBatch), and their removal
// when the process is interrupted. Internal to libiires.

#include <signal.h>

#include <string>

namespace iires::detail {

/// @brief A temporary file next to @p target, registered for removal on SIGINT/SIGTERM/SIGHUP until
/// commit() renames it (or the destructor removes it). The name is short (".iires.<pid>.<n>.tmp") whatever the target's length.
class TemporaryFile {
 public:
  explicit TemporaryFile(const std::string& target);
  ~TemporaryFile();  ///< removes the file unless it was renamed by commit()
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;
  TemporaryFile(TemporaryFile&& other) noexcept;
  TemporaryFile& operator=(TemporaryFile&&) = delete;

  const std::string& path() const { return path_; }
  const std::string& target() const { return target_; }
  /// Renames the file over its target. @return an empty string, or the reason it failed.
  std::string commit();

 private:
  std::string path_, target_;
  int slot_ = -1;  ///< index in the signal handler's table, -1 when not registered
  bool committed_ = false;
};

/// @brief Blocks SIGINT/SIGTERM/SIGHUP while alive, so that a batch's renames run to the end (the signal is
/// delivered when the guard ends).
class SignalBlock {
 public:
  SignalBlock();
  ~SignalBlock();
  SignalBlock(const SignalBlock&) = delete;
  SignalBlock& operator=(const SignalBlock&) = delete;

 private:
  sigset_t saved_;
};

}  // namespace iires::detail
